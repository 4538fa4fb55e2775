// Byte order on every target: LCM puts big-endian bytes on the wire and in log files whatever the
// host's order. These tests build the expected bytes by hand with shifts (independent of the host's order
// and of lcm-gen's code) and compare them with what the generated encode() writes, what
// msgs::checkEncoding()/decodeMessage() accept, and what platform::LcmLogReplay reads back from a log file
// written byte by byte. They use no LCM runtime, so they run on every target, the big-endian PowerPC too
// (where LCM's transport is not built: toolchains/README.md).
#include <areomap/tiepoints_t.hpp>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "platform/posix/LcmLogReplay.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using areomap::Status;

namespace {

// Big-endian writer: each value goes out most significant byte first, by shifts.
struct BigEndianBytes {
  std::vector<uint8_t> bytes;
  void put(uint64_t value, int size) {
    for (int i = size - 1; i >= 0; --i) bytes.push_back(static_cast<uint8_t>(value >> (8 * i)));
  }
  void putDouble(double value) {
    uint64_t bits = 0;
    static_assert(sizeof(bits) == sizeof(value), "IEEE 754 binary64");
    std::memcpy(&bits, &value, sizeof(bits));  // the value's bits as an integer, in any host order
    put(bits, 8);
  }
  void putString(const std::string& s) {
    put(static_cast<uint32_t>(s.size() + 1), 4);  // LCM: length including the final NUL
    bytes.insert(bytes.end(), s.begin(), s.end());
    bytes.push_back(0);
  }
};

areomap::tiepoints_t makeTiePoints() {
  areomap::tiepoints_t m;
  m.utime = 0x0102030405060708LL;
  m.sequence = -2;
  m.panorama = "sol0042_pano";
  m.pair_id = 0x0A0B0C0D;
  m.num_images = 2;
  m.image_stems = {"left_0001", "right_0001"};
  m.num_observations = 3;
  m.point_id = {1, 0x01020304, -1};
  m.image_index = {0, 1, 0x0102};
  m.sample_px = {1.5, -0.25, 1023.875};
  m.line_px = {0.0, 511.5, -1.0e-3};
  m.kind = {areomap::tiepoints_t::KIND_INTRA, areomap::tiepoints_t::KIND_INTER, -1};
  return m;
}

// The wire bytes of makeTiePoints(), field by field in the order of msgs/tiepoints_t.lcm.
std::vector<uint8_t> expectedTiePointBytes(const areomap::tiepoints_t& m) {
  BigEndianBytes b;
  b.put(static_cast<uint64_t>(areomap::tiepoints_t::getHash()), 8);
  b.put(static_cast<uint64_t>(m.utime), 8);
  b.put(static_cast<uint64_t>(m.sequence), 8);
  b.putString(m.panorama);
  b.put(static_cast<uint32_t>(m.pair_id), 4);
  b.put(static_cast<uint32_t>(m.num_images), 4);
  for (const std::string& s : m.image_stems) b.putString(s);
  b.put(static_cast<uint32_t>(m.num_observations), 4);
  for (int32_t v : m.point_id) b.put(static_cast<uint32_t>(v), 4);
  for (int16_t v : m.image_index) b.put(static_cast<uint16_t>(v), 2);
  for (double v : m.sample_px) b.putDouble(v);
  for (double v : m.line_px) b.putDouble(v);
  for (int8_t v : m.kind) b.put(static_cast<uint8_t>(v), 1);
  return b.bytes;
}

std::vector<uint8_t> encode(const areomap::tiepoints_t& m) {
  std::vector<uint8_t> bytes(static_cast<std::size_t>(m.getEncodedSize()));
  const int used = m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  CHECK_EQUAL(static_cast<int>(bytes.size()), used);
  return bytes;
}

// FNV-1a, 64 bits: a fingerprint of bytes to compare across targets.
uint64_t fnv1a(const std::vector<uint8_t>& bytes) {
  uint64_t h = 14695981039346656037ull;
  for (uint8_t c : bytes) h = (h ^ c) * 1099511628211ull;
  return h;
}

std::string hex(const uint8_t* p, std::size_t n) {
  std::string s;
  char two[3];
  for (std::size_t i = 0; i < n; ++i) {
    std::snprintf(two, sizeof(two), "%02x", p[i]);
    s += two;
  }
  return s;
}

}  // namespace

TEST_GROUP(ByteOrder){};

TEST(ByteOrder, GeneratedEncodeWritesBigEndian) {
  const areomap::tiepoints_t m = makeTiePoints();
  const std::vector<uint8_t> bytes = encode(m);
  const std::vector<uint8_t> expected = expectedTiePointBytes(m);
  CHECK_EQUAL(expected.size(), bytes.size());
  CHECK(expected == bytes);
  // Literal bytes, independent of both writers: utime right after the 8-byte fingerprint, and the first
  // sample (1.5 = 0x3FF8000000000000) after the strings and integer arrays.
  STRCMP_EQUAL("0102030405060708", hex(bytes.data() + 8, 8).c_str());
  const std::size_t strings = (4 + 13) + (4 + 10) + (4 + 11);
  const std::size_t first_sample = 8 + 8 + 8 + strings + 4 + 4 + 4 + 3 * 4 + 3 * 2;
  STRCMP_EQUAL("3ff8000000000000", hex(bytes.data() + first_sample, 8).c_str());
  std::printf("byte order: host is %s-endian; tiepoints_t fingerprint %016llx, %zu bytes, FNV-1a %016llx\n",
              __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__ ? "big" : "little",
              static_cast<unsigned long long>(areomap::tiepoints_t::getHash()), bytes.size(),
              static_cast<unsigned long long>(fnv1a(bytes)));
  // Golden figures measured on x86-64 (the same on aarch64 and powerpc): the fingerprint lcm-gen's code
  // computes at run time and the whole encoding. A change of msgs/tiepoints_t.lcm changes both (and is a new
  // type, DESIGN.md "Messages").
  CHECK(areomap::tiepoints_t::getHash() == static_cast<int64_t>(0xbf4e977d7eb4b9eaull));
  CHECK(fnv1a(bytes) == 0xf84e0e49456357cbull);
}

TEST(ByteOrder, SchemaCheckAndDecodeAcceptTheWireBytes) {
  const areomap::tiepoints_t m = makeTiePoints();
  std::vector<uint8_t> bytes = expectedTiePointBytes(m);  // the hand-made bytes, not encode()'s
  const char* type = areomap::tiepoints_t::getTypeName();
  const auto hash = static_cast<uint64_t>(areomap::tiepoints_t::getHash());
  CHECK(ok(areomap::msgs::checkEncoding(type, hash, bytes.data(), bytes.size())));
  // One byte short ends inside the last array; a changed fingerprint byte is another type.
  CHECK_EQUAL(static_cast<int>(Status::kTruncated),
              static_cast<int>(areomap::msgs::checkEncoding(type, hash, bytes.data(), bytes.size() - 1)));
  bytes[7] ^= 0x01;
  CHECK_EQUAL(static_cast<int>(Status::kCorruptData),
              static_cast<int>(areomap::msgs::checkEncoding(type, hash, bytes.data(), bytes.size())));
  bytes[7] ^= 0x01;

  areomap::tiepoints_t out;
  CHECK(ok(areomap::msgs::decodeMessage(bytes.data(), bytes.size(), out)));
  CHECK(out.utime == m.utime);
  CHECK(out.sequence == m.sequence);
  STRCMP_EQUAL(m.panorama.c_str(), out.panorama.c_str());
  CHECK_EQUAL(m.pair_id, out.pair_id);
  CHECK(out.image_stems == m.image_stems);
  CHECK(out.point_id == m.point_id);
  CHECK(out.image_index == m.image_index);
  CHECK(out.sample_px == m.sample_px);  // exact: the bits travel unchanged
  CHECK(out.line_px == m.line_px);
  CHECK(out.kind == m.kind);
}

namespace {

struct Received {
  int count = 0;
  std::size_t bytes = 0;
  uint8_t copy[4096] = {0};
};

void onTiePoints(void* context, const char* /*channel*/, const uint8_t* data, std::size_t size) {
  auto* r = static_cast<Received*>(context);
  ++r->count;
  r->bytes = size;
  if (size <= sizeof(r->copy)) std::memcpy(r->copy, data, size);
}

uint8_t g_replay_buffer[1u << 16];

}  // namespace

TEST(ByteOrder, LogReplayReadsBigEndianEventHeaders) {
  const std::vector<uint8_t> payload = expectedTiePointBytes(makeTiePoints());
  const std::string other_channel = "AREOMAP_OTHER";
  const std::vector<uint8_t> other_payload = {0xde, 0xad, 0xbe, 0xef};
  // LCM's event log (lcm/eventlog.c): sync word, event number, utime (int64), channel length, data length
  // (int32), channel (no NUL), data; every integer big-endian.
  BigEndianBytes log;
  const int64_t utime0 = 0x0001020304050607LL;
  const int64_t utime1 = 1700000000123456LL;
  auto event = [&log](int64_t number, int64_t utime, const std::string& channel,
                      const std::vector<uint8_t>& data) {
    log.put(0xEDA1DA01u, 4);
    log.put(static_cast<uint64_t>(number), 8);
    log.put(static_cast<uint64_t>(utime), 8);
    log.put(static_cast<uint32_t>(channel.size()), 4);
    log.put(static_cast<uint32_t>(data.size()), 4);
    log.bytes.insert(log.bytes.end(), channel.begin(), channel.end());
    log.bytes.insert(log.bytes.end(), data.begin(), data.end());
  };
  event(0, utime0, areomap::channels::kTiePoints, payload);
  event(1, utime1, other_channel, other_payload);
  const std::string path = areomap::test::scratchDir("byte_order_log") + "/two_events.log";
  std::FILE* f = std::fopen(path.c_str(), "wb");
  CHECK(f != nullptr);
  CHECK_EQUAL(log.bytes.size(), std::fwrite(log.bytes.data(), 1, log.bytes.size(), f));
  std::fclose(f);

  areomap::platform::LcmLogReplay replay(g_replay_buffer, sizeof(g_replay_buffer));
  Received received;
  CHECK(ok(replay.open(path.c_str())));
  CHECK(ok(replay.subscribe(areomap::channels::kTiePoints, onTiePoints, &received)));
  areomap::HeapAllocationScope scope;
  CHECK(ok(replay.handle(0)));
  const int64_t first_utime = replay.lastEventUtime();
  CHECK(ok(replay.handle(0)));
  const int64_t second_utime = replay.lastEventUtime();
  const Status end = replay.handle(0);
  CHECK_EQUAL(0u, scope.allocations());

  CHECK(first_utime == utime0);
  CHECK(second_utime == utime1);
  CHECK_EQUAL(static_cast<int>(Status::kEndOfStream), static_cast<int>(end));
  CHECK_EQUAL(2u, static_cast<unsigned>(replay.eventsRead()));
  CHECK_EQUAL(1, received.count);  // the other channel has no subscriber
  CHECK_EQUAL(payload.size(), received.bytes);
  CHECK_EQUAL(0, std::memcmp(payload.data(), received.copy, payload.size()));
}
