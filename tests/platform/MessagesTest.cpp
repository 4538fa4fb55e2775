#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "firmware_core/base/Capacities.hpp"
#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "platform/posix/LcmTransport.hpp"
#include "tests/platform/MessageFixtures.hpp"

#include <CppUTest/TestHarness.h>

using areomap::Status;
using areomap::msgs::checkEncoding;
using areomap::msgs::decodeMessage;
using areomap::test::encode;

namespace {

// Round trip through encode/decode: the decoded message encodes to the same bytes (every field survived),
// and the check accepts exactly the encoding.
template <class Message>
Message roundTrip(const Message& original) {
  const std::vector<uint8_t> bytes = encode(original);
  CHECK(!bytes.empty());
  Message decoded{};
  CHECK_EQUAL(static_cast<int>(Status::kOk),
              static_cast<int>(decodeMessage(bytes.data(), bytes.size(), decoded)));
  const std::vector<uint8_t> again = encode(decoded);
  CHECK(bytes == again);
  return decoded;
}

// Through an LCM memq:// transport: publish the bytes on `channel`, receive them into a fixed slot, decode.
template <class Message>
Message throughMemq(const Message& original, const char* channel) {
  static std::vector<uint8_t> storage(8u * 1024u * 1024u);
  areomap::platform::LcmTransport transport;
  CHECK_EQUAL(static_cast<int>(Status::kOk), static_cast<int>(transport.open("memq://")));
  areomap::platform::MessageSlot slot;
  slot.storage = storage.data();
  slot.capacity = storage.size();
  CHECK(ok(transport.subscribe(channel, &areomap::platform::MessageSlot::store, &slot)));
  const std::vector<uint8_t> bytes = encode(original);
  CHECK(ok(transport.publish(channel, bytes.data(), bytes.size())));
  CHECK_EQUAL(static_cast<int>(Status::kOk), static_cast<int>(transport.handle(1000)));
  CHECK_EQUAL(1u, slot.received);
  CHECK_EQUAL(bytes.size(), slot.size);
  Message decoded{};
  CHECK(ok(decodeMessage(slot.storage, slot.size, decoded)));
  CHECK(encode(decoded) == bytes);
  return decoded;
}

}  // namespace

TEST_GROUP(Messages){};

TEST(Messages, SchemaOfEveryTypeParses) {
  STRCMP_EQUAL("", areomap::msgs::schemaError());
  CHECK_EQUAL(11, areomap::msgs::schemaTypeCount());
}

TEST(Messages, StereoPairRoundTrips) {
  const auto original = areomap::test::makeStereoPair(5, 300000);
  const auto a = roundTrip(original);
  const auto b = throughMemq(original, areomap::channels::kStereoPair);
  STRCMP_EQUAL("p5_L", b.left.stem.c_str());
  CHECK_EQUAL(300000, b.left.jpeg_bytes);
  CHECK_EQUAL(150000u, b.right.jpeg.size());
  DOUBLES_EQUAL(original.left.model.h_px[2], a.left.model.h_px[2], 0.0);
  CHECK_EQUAL(areomap::camera_model_t::TYPE_CAHVOR, a.right.model.type);
  // The end-of-panorama marker: same type, no images.
  areomap::stereo_pair_t end{};
  end.kind = areomap::stereo_pair_t::KIND_END_OF_PANORAMA;
  end.sequence = 64;
  const auto e = roundTrip(end);
  CHECK_EQUAL(areomap::stereo_pair_t::KIND_END_OF_PANORAMA, e.kind);
  CHECK_EQUAL(0, e.left.jpeg_bytes);
}

TEST(Messages, TiePointsRoundTrip) {
  const auto original = areomap::test::makeTiePoints(2, 500);
  roundTrip(original);
  const auto b = throughMemq(original, areomap::channels::kTiePoints);
  CHECK_EQUAL(500u, b.sample_px.size());
  STRCMP_EQUAL("a_rather_long_image_stem_that_does_not_fit_sso", b.image_stems[2].c_str());
  CHECK_EQUAL(areomap::tiepoints_t::KIND_INTER, b.kind[5]);
}

TEST(Messages, EoSolutionRoundTrips) {
  const auto original = areomap::test::makeEoSolution(3, 2 * areomap::kMaxPairs);
  roundTrip(original);
  const auto b = throughMemq(original, areomap::channels::kEoSolution);
  CHECK_EQUAL(2 * areomap::kMaxPairs, static_cast<int>(b.images.size()));
  STRCMP_EQUAL("p127_R", b.images.back().stem.c_str());
  CHECK_EQUAL(areomap::eo_entry_t::SIDE_RIGHT, b.images.back().side);
}

TEST(Messages, CoarseDemRoundTrips) {
  const auto original = areomap::test::makeCoarseDem(4, 80, 120);
  roundTrip(original);
  const auto b = throughMemq(original, areomap::channels::kCoarseDem);
  CHECK_EQUAL(9600u, b.elevation_m.size());
  DOUBLES_EQUAL(-9999.0, b.elevation_m[7], 0.0);
}

TEST(Messages, RoverStatusRoundTrips) {
  const auto original = areomap::test::makeRoverStatus(6);
  roundTrip(original);
  const auto b = throughMemq(original, areomap::channels::kRoverStatus);
  CHECK_EQUAL(1, b.rejected_by_cause[areomap::rover_status_t::CAUSE_CORRUPT_DATA]);
  STRCMP_EQUAL(original.last_error.c_str(), b.last_error.c_str());
}

TEST(Messages, ProductRoundTrips) {
  const auto original = areomap::test::makeProduct(7, 12);
  roundTrip(original);
  const auto b = throughMemq(original, areomap::channels::kProduct);
  CHECK_EQUAL(12u, b.sha256_hex.size());
  STRCMP_EQUAL("models/p11_L.cahvor", b.names[11].c_str());
}

// rover_status_t counts rejections by cause; the cause codes are the values of areomap::Status.
TEST(Messages, RejectionCausesAreStatusCodes) {
  using R = areomap::rover_status_t;
  static_assert(R::CAUSE_INVALID_ARGUMENT == static_cast<int>(Status::kInvalidArgument), "cause code");
  static_assert(R::CAUSE_MISSING_FIELD == static_cast<int>(Status::kMissingField), "cause code");
  static_assert(R::CAUSE_NOT_FINITE == static_cast<int>(Status::kNotFinite), "cause code");
  static_assert(R::CAUSE_DEGENERATE == static_cast<int>(Status::kDegenerate), "cause code");
  static_assert(R::CAUSE_BEHIND_CAMERA == static_cast<int>(Status::kBehindCamera), "cause code");
  static_assert(R::CAUSE_NO_CONVERGENCE == static_cast<int>(Status::kNoConvergence), "cause code");
  static_assert(R::CAUSE_CAPACITY_EXCEEDED == static_cast<int>(Status::kCapacityExceeded), "cause code");
  static_assert(R::CAUSE_CORRUPT_DATA == static_cast<int>(Status::kCorruptData), "cause code");
  static_assert(R::CAUSE_TRUNCATED == static_cast<int>(Status::kTruncated), "cause code");
  static_assert(R::CAUSE_UNSUPPORTED == static_cast<int>(Status::kUnsupported), "cause code");
  static_assert(R::CAUSE_NO_TEXTURE == static_cast<int>(Status::kNoTexture), "cause code");
  static_assert(R::CAUSE_IO_ERROR == static_cast<int>(Status::kIoError), "cause code");
  static_assert(R::CAUSE_TIMEOUT == static_cast<int>(Status::kTimeout), "cause code");
  static_assert(R::CAUSE_END_OF_STREAM == static_cast<int>(Status::kEndOfStream), "cause code");
  static_assert(static_cast<int>(Status::kCount) <= R::NUM_CAUSES, "one slot per Status code");
  CHECK_EQUAL(R::NUM_CAUSES, static_cast<int>(sizeof(R{}.rejected_by_cause) / sizeof(int32_t)));
}

// A receiver that reserves its message at start-up decodes a stereo pair without heap (the rover's path).
TEST(Messages, DecodeIntoReservedPairMakesNoHeapAllocation) {
  const std::vector<uint8_t> bytes = encode(areomap::test::makeStereoPair(9, 400000));
  areomap::stereo_pair_t pair{};
  pair.panorama.reserve(256);
  for (areomap::stereo_image_t* side : {&pair.left, &pair.right}) {
    side->stem.reserve(256);
    side->jpeg.reserve(areomap::kMaxJpegBytes);
  }
  Status status = Status::kCount;
  {
    areomap::HeapAllocationScope scope;
    status = decodeMessage(bytes.data(), bytes.size(), pair);
    CHECK_EQUAL(0u, scope.allocations());
  }
  CHECK(ok(status));
  CHECK_EQUAL(400000u, pair.left.jpeg.size());
  CHECK_EQUAL(static_cast<uint8_t>((1234 * 31 + 9) & 0xFF), pair.left.jpeg[1234]);
}

TEST_GROUP(MessageCheck){};

// Every prefix of an encoding is refused as truncated (or corrupt), never decoded, never a crash.
TEST(MessageCheck, EveryTruncationIsRefused) {
  const std::vector<uint8_t> bytes = encode(areomap::test::makeEoSolution(1, 4));
  areomap::HeapAllocationScope scope;
  int truncated = 0;
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    const Status s = checkEncoding(areomap::eo_solution_t::getTypeName(),
                                   static_cast<uint64_t>(areomap::eo_solution_t::getHash()), bytes.data(), n);
    CHECK(s == Status::kTruncated || s == Status::kCorruptData);
    truncated += s == Status::kTruncated ? 1 : 0;
  }
  CHECK_EQUAL(0u, scope.allocations());
  std::printf("eo_solution_t: %zu prefixes refused, %d as truncated\n", bytes.size(), truncated);
  CHECK_EQUAL(static_cast<int>(bytes.size()), truncated);
}

TEST(MessageCheck, CorruptEncodingsGiveStatuses) {
  std::vector<uint8_t> bytes = encode(areomap::test::makeStereoPair(1, 1000));
  areomap::stereo_pair_t pair{};
  // Another type's bytes: wrong fingerprint.
  const std::vector<uint8_t> status_bytes = encode(areomap::test::makeRoverStatus(1));
  CHECK_EQUAL(static_cast<int>(Status::kCorruptData),
              static_cast<int>(decodeMessage(status_bytes.data(), status_bytes.size(), pair)));
  // A byte left over.
  std::vector<uint8_t> longer = bytes;
  longer.push_back(0);
  CHECK_EQUAL(static_cast<int>(Status::kCorruptData),
              static_cast<int>(decodeMessage(longer.data(), longer.size(), pair)));
  // The panorama string length (after hash 8 + utime 8 + sequence 8 + kind 1) set to 0, negative, huge.
  const std::size_t string_length_at = 25;
  const uint8_t lengths[][4] = {{0, 0, 0, 0}, {0xFF, 0xFF, 0xFF, 0xF0}, {0x7F, 0xFF, 0xFF, 0xFF}};
  const Status expected[] = {Status::kCorruptData, Status::kCorruptData, Status::kTruncated};
  for (int i = 0; i < 3; ++i) {
    std::vector<uint8_t> bad = bytes;
    std::memcpy(&bad[string_length_at], lengths[i], 4);
    CHECK_EQUAL(static_cast<int>(expected[i]), static_cast<int>(decodeMessage(bad.data(), bad.size(), pair)));
  }
  // The left JPEG byte count set to a negative and to a huge value: the generated decode would resize first.
  const areomap::stereo_pair_t original = areomap::test::makeStereoPair(1, 1000);
  const std::size_t jpeg_count_at =
      25 + 4 + original.panorama.size() + 1 + 4 * 4 + 1 + 4 + original.left.stem.size() + 1 + 4 + 4;
  CHECK_EQUAL(0, bytes[jpeg_count_at]);
  CHECK_EQUAL(1000, (bytes[jpeg_count_at + 2] << 8) | bytes[jpeg_count_at + 3]);
  std::vector<uint8_t> bad = bytes;
  bad[jpeg_count_at] = 0x80;
  CHECK_EQUAL(static_cast<int>(Status::kCorruptData),
              static_cast<int>(decodeMessage(bad.data(), bad.size(), pair)));
  bad[jpeg_count_at] = 0x40;
  CHECK_EQUAL(static_cast<int>(Status::kTruncated),
              static_cast<int>(decodeMessage(bad.data(), bad.size(), pair)));
  // A string without its NUL terminator.
  bad = bytes;
  bad[string_length_at + 4 + original.panorama.size()] = 'x';
  CHECK_EQUAL(static_cast<int>(Status::kCorruptData),
              static_cast<int>(decodeMessage(bad.data(), bad.size(), pair)));
  // Unknown type name, null data.
  CHECK_EQUAL(static_cast<int>(Status::kInvalidArgument),
              static_cast<int>(checkEncoding("no_such_t", 0, bytes.data(), bytes.size())));
  CHECK_EQUAL(static_cast<int>(Status::kInvalidArgument),
              static_cast<int>(checkEncoding("stereo_pair_t", 0, nullptr, 0)));
}

// Random byte damage: whatever the check accepts decodes completely; nothing crashes or throws.
TEST(MessageCheck, RandomDamageNeverCrashes) {
  const std::vector<uint8_t> bytes = encode(areomap::test::makeTiePoints(1, 40));
  uint32_t state = 12345;
  int accepted = 0;
  int refused = 0;
  for (int trial = 0; trial < 5000; ++trial) {
    std::vector<uint8_t> bad = bytes;
    for (int k = 0; k < 3; ++k) {
      state = state * 1664525u + 1013904223u;
      const std::size_t at = 8 + (state >> 8) % (bad.size() - 8);  // keep the fingerprint
      state = state * 1664525u + 1013904223u;
      bad[at] = static_cast<uint8_t>(state >> 24);
    }
    areomap::tiepoints_t t{};
    if (ok(decodeMessage(bad.data(), bad.size(), t))) {
      ++accepted;
      CHECK(encode(t) == bad);
    } else {
      ++refused;
    }
  }
  std::printf("tiepoints_t with 3 random bytes damaged: %d accepted (still well formed), %d refused\n",
              accepted, refused);
  CHECK(refused > 0);
}
