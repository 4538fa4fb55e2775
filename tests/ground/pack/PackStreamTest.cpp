// The pack tool's stream and the rover tool (ground/pack/Pack.hpp, firmware_core/node/app): the tiny
// panorama packed as one ordered, complete stream whose log reads back with the platform's replay, and the
// areomap-rover and areomap-pack binaries' exit codes.
#include <cstdint>
#include <string>
#include <vector>

#include "areomap/stereo_pair_t.hpp"
#include "firmware_core/base/Capacities.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/pack/Pack.hpp"
#include "msgs/MessageCheck.hpp"
#include "platform/posix/LcmLogReplay.hpp"
#include "platform/posix/TurboJpegCodec.hpp"
#include "tests/ground/pack/TinyStream.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

// CppUTest prints a Status by its name (defined here: the CI's sanitizer subset compiles only this file of
// the group).
SimpleString StringFrom(areomap::Status status) {
  return SimpleString(areomap::statusName(status));
}

namespace {

const std::string& packStreamDataset() {
  CHECK(!test::tinyPackDataset().empty());
  return test::tinyPackDataset();
}

}  // namespace

TEST_GROUP(PackStream){};

// One event per pair in order, sequence numbers 0..n-1, the marker last, timestamps interval_s apart,
// decodable JPEGs of the image size, rig values equal to what setRigConstraints estimates.
TEST(PackStream, TinyStreamIsOrderedAndComplete) {
  const Dataset dataset = readDataset(packStreamDataset());
  const std::vector<LogEvent>& events = test::tinyPackStream();
  CHECK_EQUAL(dataset.pairs.size() + 1, events.size());
  platform::TurboJpegCodec codec;
  CHECK_EQUAL(Status::kOk, codec.open());
  std::vector<uint8_t> pixels(kMaxImagePixels);
  for (std::size_t k = 0; k < events.size(); ++k) {
    stereo_pair_t p;
    CHECK_EQUAL(Status::kOk, msgs::decodeMessage(events[k].data.data(), events[k].data.size(), p));
    CHECK_EQUAL(static_cast<int64_t>(k), p.sequence);
    CHECK_EQUAL(1'700'000'000'000'000 + static_cast<int64_t>(k) * 3'000'000, p.utime);
    if (k == dataset.pairs.size()) {
      CHECK_EQUAL(stereo_pair_t::KIND_END_OF_PANORAMA, p.kind);
      continue;
    }
    CHECK_EQUAL(stereo_pair_t::KIND_PAIR, p.kind);
    STRCMP_EQUAL(dataset.pairs[k].left.stem.c_str(), p.left.stem.c_str());
    int32_t w = 0, h = 0;
    CHECK_EQUAL(Status::kOk,
                codec.decodeGray(p.left.jpeg.data(), p.left.jpeg.size(), pixels.data(), pixels.size(), w, h));
    CHECK_EQUAL(p.left.width_px, w);
    CHECK_EQUAL(p.left.height_px, h);
    CHECK_TRUE(p.has_right == dataset.pairs[k].right.has_value());
  }
  // The log file reads back with the platform's replay (the same format lcm-logger writes).
  const std::string log = test::scratchDir("pack-log") + "/tiny.lcm";
  writeEventLog(log, events);
  std::vector<uint8_t> buffer(2 * kMaxJpegBytes + 65536);
  platform::LcmLogReplay replay(buffer.data(), buffer.size());
  CHECK_EQUAL(Status::kOk, replay.open(log.c_str()));
  std::size_t read = 0;
  while (replay.handle(0) == Status::kOk) ++read;
  CHECK_EQUAL(events.size(), read);
}
TEST_GROUP(RoverTool){};

// The areomap-rover binary on a file:// replay of the tiny log: exit 0; --help 0; no --lcm 2.
TEST(RoverTool, ReplaysALogAndExits) {
  const std::string dir = test::scratchDir("rover-tool");
  writeEventLog(dir + "/tiny.lcm", test::tinyPackStream());
  CHECK_EQUAL(0, test::runTool("areomap-rover", "--lcm file://" + dir + "/tiny.lcm --quiet"));
  CHECK_EQUAL(0, test::runTool("areomap-rover", "--help"));
  CHECK_EQUAL(2, test::runTool("areomap-rover", ""));
  CHECK_EQUAL(2, test::runTool("areomap-pack", packStreamDataset()));
  CHECK_EQUAL(1, test::runTool("areomap-pack", dir + "/missing --out " + dir + "/x.lcm"));
}
