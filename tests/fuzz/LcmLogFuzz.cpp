// Fuzz target: an LCM log file (what areomap-pack writes and areomap-rover / areomap-ground replay through
// file://) read by platform LcmLogReplay into a fixed buffer, every AREOMAP_STEREO_PAIR event then through
// the rover's checks (checkEncoding, checkStereoPairCapacity, decode). The buffer is 64 KiB so that the
// "event larger than the buffer" path is reached by small inputs.
// Invariants: the replay ends (kEndOfStream or an error) within one call per 17 bytes of input (an event
// header alone is 28 bytes); a delivered event is never larger than the buffer.
#include <string>

#include "areomap/stereo_pair_t.hpp"
#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
#include "msgs/adapters/MessageAdapters.hpp"
#include "platform/posix/LcmLogReplay.hpp"
#include "tests/fuzz/FuzzSupport.hpp"

namespace {

using areomap::Status;
using areomap::fuzz::fail;

constexpr std::size_t kBufferBytes = 64 * 1024;
uint8_t g_buffer[kBufferBytes];

void onPair(void* /*context*/, const char* /*channel*/, const uint8_t* data, std::size_t size) {
  if (size > kBufferBytes) fail("lcm_log", "an event larger than the buffer was delivered");
  static areomap::stereo_pair_t pair = [] {
    areomap::stereo_pair_t p;
    areomap::prepareStereoPair(p);
    return p;
  }();
  const char* field = "";
  if (!areomap::ok(areomap::msgs::checkEncoding(areomap::stereo_pair_t::getTypeName(),
                                                static_cast<uint64_t>(areomap::stereo_pair_t::getHash()), data,
                                                size))) {
    return;
  }
  if (!areomap::ok(areomap::checkStereoPairCapacity(data, size, field))) return;
  if (!areomap::ok(areomap::msgs::decodeMessage(data, size, pair))) fail("lcm_log", "a checked pair does not decode");
}

void onAny(void* context, const char* /*channel*/, const uint8_t* /*data*/, std::size_t size) {
  if (size > kBufferBytes) fail("lcm_log", "an event larger than the buffer was delivered");
  ++*static_cast<int*>(context);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  static const std::string path = areomap::fuzz::scratchFolder() + "/input.lcm";
  areomap::fuzz::writeFile(path, data, size);
  areomap::platform::LcmLogReplay replay(g_buffer, sizeof g_buffer);
  if (!areomap::ok(replay.open(("file://" + path + "?speed=0").c_str()))) fail("lcm_log", "open");
  int others = 0;
  if (!areomap::ok(replay.subscribe(areomap::channels::kStereoPair, onPair, nullptr)) ||
      !areomap::ok(replay.subscribe(areomap::channels::kRoverStatus, onAny, &others))) {
    fail("lcm_log", "subscribe");
  }
  const std::size_t max_calls = size / 17 + 2;
  for (std::size_t call = 0;; ++call) {
    if (call > max_calls) fail("lcm_log", "the replay does not end");
    const Status s = replay.handle(0);
    if (s == Status::kOk || s == Status::kCapacityExceeded) {
      if (s == Status::kCapacityExceeded && replay.eventsTooLarge() == 0) break;  // channel name too long
      continue;
    }
    break;
  }
  return 0;
}
