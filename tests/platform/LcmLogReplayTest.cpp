#include <cstdio>
#include <string>
#include <vector>

#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "platform/posix/LcmLogReplay.hpp"
#include "platform/posix/LcmTransport.hpp"
#include "tests/platform/MessageFixtures.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using areomap::Status;
using areomap::platform::LcmLogReplay;
using areomap::platform::MessageSlot;

namespace {

int code(Status s) {
  return static_cast<int>(s);
}

constexpr int kPairs = 12;
constexpr int32_t kJpegBytes = 150000;

// Writes kPairs stereo pairs and a rover status after each through LCM's own file:// writer.
std::string writeLog(const char* name) {
  const std::string path = areomap::test::scratchDir(name) + "/stream.log";
  areomap::platform::LcmTransport writer;
  CHECK(ok(writer.open(("file://" + path + "?mode=w").c_str())));
  for (int i = 0; i < kPairs; ++i) {
    const std::vector<uint8_t> pair = areomap::test::encode(areomap::test::makeStereoPair(i, kJpegBytes));
    CHECK(ok(writer.publish(areomap::channels::kStereoPair, pair.data(), pair.size())));
    const std::vector<uint8_t> status = areomap::test::encode(areomap::test::makeRoverStatus(i));
    CHECK(ok(writer.publish(areomap::channels::kRoverStatus, status.data(), status.size())));
  }
  return path;
}

std::vector<uint8_t> readFile(const std::string& path) {
  std::vector<uint8_t> bytes;
  std::FILE* f = std::fopen(path.c_str(), "rb");
  for (int c = f ? std::fgetc(f) : EOF; c != EOF; c = std::fgetc(f)) bytes.push_back(static_cast<uint8_t>(c));
  if (f) std::fclose(f);
  return bytes;
}

void writeFile(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  std::fwrite(bytes.data(), 1, bytes.size(), f);
  std::fclose(f);
}

uint8_t g_buffer[1u << 20];

}  // namespace

TEST_GROUP(LcmLogReplay){};

// The whole log comes back, in order, no sequence gap, and handle() makes no heap allocation.
TEST(LcmLogReplay, ReplaysCompleteInOrderWithoutHeap) {
  const std::string path = writeLog("log_replay");
  LcmLogReplay replay(g_buffer, sizeof(g_buffer));
  CHECK(ok(replay.open(("file://" + path + "?speed=0").c_str())));
  MessageSlot slot;
  // The replay buffer is valid during the call only: the pipeline copies into its own fixed buffer.
  static uint8_t copy[1u << 20];
  slot.storage = copy;
  slot.capacity = sizeof(copy);
  CHECK(ok(replay.subscribe(areomap::channels::kStereoPair, &MessageSlot::store, &slot)));
  std::vector<int64_t> sequences;
  sequences.reserve(kPairs);
  uint64_t allocations = 0;
  Status status = Status::kOk;
  for (int i = 0; i < 4 * kPairs && status != Status::kEndOfStream; ++i) {
    const uint64_t before_received = slot.received;
    const uint64_t before = areomap::heapAllocationCountThisThread();
    status = replay.handle(0);
    allocations += areomap::heapAllocationCountThisThread() - before;
    CHECK(ok(status) || status == Status::kEndOfStream);
    if (slot.received != before_received) {
      areomap::stereo_pair_t pair{};
      CHECK(ok(areomap::msgs::decodeMessage(slot.storage, slot.size, pair)));
      CHECK(areomap::test::encode(pair) == areomap::test::encode(areomap::test::makeStereoPair(
                                               static_cast<int>(pair.sequence), kJpegBytes)));
      sequences.push_back(pair.sequence);
    }
  }
  std::printf("log replay: %llu events, %zu pairs, %llu heap allocations in handle(), then %s\n",
              static_cast<unsigned long long>(replay.eventsRead()), sequences.size(),
              static_cast<unsigned long long>(allocations), areomap::statusName(status));
  CHECK_EQUAL(code(Status::kEndOfStream), code(status));
  CHECK_EQUAL(static_cast<uint64_t>(2 * kPairs), replay.eventsRead());
  CHECK_EQUAL(static_cast<std::size_t>(kPairs), sequences.size());
  for (int i = 0; i < kPairs; ++i) CHECK_EQUAL(i, sequences[i]);
  CHECK_EQUAL(0u, allocations);
  CHECK(replay.lastEventUtime() > 0);
}

TEST(LcmLogReplay, DamagedLogsGiveStatuses) {
  const std::string path = writeLog("log_replay_damaged");
  const std::vector<uint8_t> log = readFile(path);
  LcmLogReplay replay(g_buffer, sizeof(g_buffer));
  // Cut inside the third event (the second pair): two events, then kTruncated.
  std::vector<uint8_t> cut(log.begin(), log.begin() + static_cast<long>(log.size() / kPairs + 1000));
  writeFile(path + ".cut", cut);
  CHECK(ok(replay.open((path + ".cut").c_str())));
  Status status = Status::kOk;
  int events = 0;
  for (int i = 0; i < 10 && ok(status); ++i) {
    status = replay.handle(0);
    events += ok(status) ? 1 : 0;
  }
  std::printf("log cut at %zu of %zu bytes: %d events, then %s\n", cut.size(), log.size(), events,
              areomap::statusName(status));
  CHECK_EQUAL(code(Status::kTruncated), code(status));
  // A damaged sync word: kCorruptData, and it stays so.
  std::vector<uint8_t> bad = log;
  bad[0] ^= 0xFF;
  writeFile(path + ".bad", bad);
  CHECK(ok(replay.open((path + ".bad").c_str())));
  CHECK_EQUAL(code(Status::kCorruptData), code(replay.handle(0)));
  CHECK_EQUAL(code(Status::kCorruptData), code(replay.handle(0)));
  // An event larger than the buffer is skipped and counted; the next one is read.
  static uint8_t small[4096];
  LcmLogReplay tight(small, sizeof(small));
  CHECK(ok(tight.open(path.c_str())));
  CHECK_EQUAL(code(Status::kCapacityExceeded), code(tight.handle(0)));  // a stereo pair
  CHECK_EQUAL(code(Status::kOk), code(tight.handle(0)));                // its rover status fits
  CHECK_EQUAL(1u, tight.eventsTooLarge());
  CHECK_EQUAL(code(Status::kIoError), code(tight.publish("X", small, 1)));
  CHECK_EQUAL(code(Status::kIoError), code(replay.open("/no/such/file.log")));
}
