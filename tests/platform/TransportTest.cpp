#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
#include "platform/TransportUrl.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "platform/posix/LcmTransport.hpp"
#include "platform/stub/MemoryTransport.hpp"
#include "tests/platform/MessageFixtures.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using areomap::Status;
using areomap::platform::LcmTransport;
using areomap::platform::MessageSlot;

namespace {

int code(Status s) {
  return static_cast<int>(s);
}

// Collects the sequence numbers of received stereo pairs and whether each decoded intact.
struct PairCollector {
  std::vector<int64_t> sequences;
  int bad = 0;
  std::size_t bytes = 0;
  static void onMessage(void* context, const char* /*channel*/, const uint8_t* data, std::size_t size) {
    auto& self = *static_cast<PairCollector*>(context);
    areomap::stereo_pair_t pair{};
    if (!ok(areomap::msgs::decodeMessage(data, size, pair))) {
      ++self.bad;
      return;
    }
    // The JPEG bytes follow the fixture's pattern: a damaged reassembly would show.
    for (std::size_t i = 0; i < pair.left.jpeg.size(); i += 997) {
      if (pair.left.jpeg[i] != static_cast<uint8_t>((i * 31 + pair.sequence) & 0xFF)) {
        ++self.bad;
        return;
      }
    }
    self.sequences.push_back(pair.sequence);
    self.bytes = size;
  }
};

}  // namespace

TEST_GROUP(TransportUrl){};

TEST(TransportUrl, UdpmDefaultsAreSafe) {
  char url[areomap::platform::kMaxUrlChars];
  CHECK(ok(areomap::platform::completeUrl("", url, sizeof(url))));
  STRCMP_EQUAL("udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608", url);
  CHECK(ok(areomap::platform::completeUrl("udpm://239.255.76.1:7000?ttl=1", url, sizeof(url))));
  STRCMP_EQUAL("udpm://239.255.76.1:7000?ttl=1&recv_buf_size=8388608", url);  // the operator's ttl is kept
  CHECK(
      ok(areomap::platform::completeUrl("udpm://239.255.76.1:7000?recv_buf_size=100000", url, sizeof(url))));
  STRCMP_EQUAL("udpm://239.255.76.1:7000?recv_buf_size=100000&ttl=0", url);
  CHECK(ok(areomap::platform::completeUrl("file:///tmp/x.log?mode=w", url, sizeof(url))));
  STRCMP_EQUAL("file:///tmp/x.log?mode=w", url);
  CHECK_EQUAL(code(Status::kInvalidArgument),
              code(areomap::platform::completeUrl("tcp://x", url, sizeof(url))));
  CHECK_EQUAL(code(Status::kCapacityExceeded),
              code(areomap::platform::completeUrl("udpm://239.1.1.1:1", url, 20)));
  int64_t value = 0;
  CHECK(areomap::platform::urlOption("udpm://a:1?ttl=3&recv_buf_size=77", "recv_buf_size", value));
  CHECK_EQUAL(77, value);
  CHECK_FALSE(areomap::platform::urlOption("udpm://a:1?ttl=x", "ttl", value));
}

TEST_GROUP(MemoryTransport){};

TEST(MemoryTransport, DeliversInOrderWithoutHeap) {
  static uint8_t storage[64 * 1024];
  static uint8_t received[4096];
  areomap::platform::MemoryTransport transport(storage, sizeof(storage));
  MessageSlot slot;
  slot.storage = received;
  slot.capacity = 100;
  areomap::HeapAllocationScope scope;
  CHECK(ok(transport.subscribe("A", &MessageSlot::store, &slot)));
  uint8_t payload[200];
  for (int i = 0; i < 200; ++i) payload[i] = static_cast<uint8_t>(i);
  CHECK(ok(transport.publish("A", payload, 10)));
  CHECK(ok(transport.publish("B", payload, 20)));  // nobody listens: consumed silently
  CHECK(ok(transport.publish("A", payload + 1, 30)));
  CHECK(ok(transport.publish("A", payload, 200)));  // larger than the slot
  CHECK_EQUAL(code(Status::kOk), code(transport.handle(0)));
  CHECK_EQUAL(10u, slot.size);
  CHECK(ok(transport.handle(0)));
  CHECK_EQUAL(1u, slot.received);
  CHECK(ok(transport.handle(0)));
  CHECK_EQUAL(30u, slot.size);
  CHECK_EQUAL(1, slot.storage[0]);
  CHECK(ok(transport.handle(0)));
  CHECK_EQUAL(code(Status::kCapacityExceeded), code(slot.status));
  CHECK_EQUAL(1u, slot.dropped);
  CHECK_EQUAL(code(Status::kTimeout), code(transport.handle(0)));
  static uint8_t big[70 * 1024];
  CHECK_EQUAL(code(Status::kCapacityExceeded), code(transport.publish("A", big, sizeof(big))));
  CHECK_EQUAL(1u, transport.refused());
  CHECK_EQUAL(0u, scope.allocations());
}

TEST_GROUP(LcmTransport){};

TEST(LcmTransport, RefusesBadUrlsAndChannels) {
  LcmTransport transport;
  CHECK_EQUAL(code(Status::kInvalidArgument), code(transport.open("tcp://nowhere")));
  CHECK_EQUAL(code(Status::kIoError), code(transport.open("file:///no/such/dir/x.log")));
  CHECK(ok(transport.open("memq://")));
  const uint8_t byte = 1;
  CHECK_EQUAL(code(Status::kInvalidArgument), code(transport.publish("A.*", &byte, 1)));
  CHECK_EQUAL(code(Status::kInvalidArgument), code(transport.publish("", &byte, 1)));
  CHECK_EQUAL(code(Status::kTimeout), code(transport.handle(10)));
}

// A camera stream recorded through file:// reads back complete, in order, with no sequence gap.
TEST(LcmTransport, FileLogReadsBackCompleteInOrder) {
  const std::string path = areomap::test::scratchDir("lcm_file_log") + "/stream.log";
  constexpr int kPairs = 20;
  {
    LcmTransport writer;
    CHECK(ok(writer.open(("file://" + path + "?mode=w").c_str())));
    for (int i = 0; i < kPairs; ++i) {
      const std::vector<uint8_t> bytes = areomap::test::encode(areomap::test::makeStereoPair(i, 200000));
      CHECK(ok(writer.publish(areomap::channels::kStereoPair, bytes.data(), bytes.size())));
      const std::vector<uint8_t> status = areomap::test::encode(areomap::test::makeRoverStatus(i));
      CHECK(ok(writer.publish(areomap::channels::kRoverStatus, status.data(), status.size())));
    }
  }
  LcmTransport reader;
  CHECK(ok(reader.open(("file://" + path + "?speed=0").c_str())));
  CHECK_EQUAL(code(Status::kIoError), code(reader.publish("X", nullptr, 0)));  // a replay is read-only
  PairCollector pairs;
  CHECK(ok(reader.subscribe(areomap::channels::kStereoPair, &PairCollector::onMessage, &pairs)));
  Status status = Status::kOk;
  int handled = 0;
  for (int i = 0; i < 10 * kPairs && status != Status::kEndOfStream; ++i) {
    status = reader.handle(1000);
    handled += ok(status) ? 1 : 0;
    CHECK(ok(status) || status == Status::kEndOfStream);
  }
  std::printf("file:// log: %d events handled, %zu pairs decoded, then %s\n", handled, pairs.sequences.size(),
              areomap::statusName(status));
  CHECK_EQUAL(code(Status::kEndOfStream), code(status));
  CHECK_EQUAL(0, pairs.bad);
  CHECK_EQUAL(static_cast<std::size_t>(kPairs), pairs.sequences.size());
  for (int i = 0; i < static_cast<int>(pairs.sequences.size()); ++i) CHECK_EQUAL(i, pairs.sequences[i]);

  // Heap on the calling thread of a replay that only copies into a fixed slot: LCM's file provider reads
  // each event into a fresh allocation (lcm_eventlog_read_next_event), so a file:// replay is not heap-free
  // on the pipeline thread, unlike udpm (UdpmTest). Printed for the record; not a property asserted here.
  LcmTransport replay;
  CHECK(ok(replay.open(("file://" + path + "?speed=0").c_str())));
  static std::vector<uint8_t> slot_storage(1u << 20);
  MessageSlot slot;
  slot.storage = slot_storage.data();
  slot.capacity = slot_storage.size();
  CHECK(ok(replay.subscribe(areomap::channels::kStereoPair, &MessageSlot::store, &slot)));
  CHECK(ok(replay.subscribe(areomap::channels::kRoverStatus, &MessageSlot::store, &slot)));
  const uint64_t before = areomap::heapAllocationCountThisThread();
  status = Status::kOk;
  for (int i = 0; i < 10 * kPairs && status != Status::kEndOfStream; ++i) status = replay.handle(1000);
  std::printf(
      "file:// replay into a fixed slot: %llu messages, %llu heap allocations on the calling thread\n",
      static_cast<unsigned long long>(slot.received),
      static_cast<unsigned long long>(areomap::heapAllocationCountThisThread() - before));
  CHECK_EQUAL(static_cast<uint64_t>(2 * kPairs), slot.received);
}
