#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "areomap/site_t.hpp"
#include "areomap/stereo_pair_t.hpp"
#include "msgs/MessageCheck.hpp"
#include "msgs/adapters/MessageAdapters.hpp"
#include "tests/msgs/SiteFixture.hpp"
#include "platform/heap/HeapCounter.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

CameraModel cahvor() {
  CameraModel m;
  m.type = CameraType::kCahvor;
  m.c = Vec3(0.5, -0.2, -1.5);
  m.a = Vec3(0.8, 0.6, 0.0);
  m.h = Vec3(-400.0, 700.0, 10.0);
  m.v = Vec3(300.0, 200.0, 800.0);
  m.o = Vec3(0.8, 0.6, 0.0);
  m.r = Vec3(0.0, -0.1, 0.02);
  m.width = 1024;
  m.height = 1024;
  return m;
}

std::vector<uint8_t> encode(const stereo_pair_t& p) {
  std::vector<uint8_t> b(static_cast<std::size_t>(p.getEncodedSize()));
  CHECK_EQUAL(static_cast<int>(b.size()), p.encode(b.data(), 0, static_cast<int>(b.size())));
  return b;
}

stereo_pair_t pairWith(std::size_t stem_chars, int32_t jpeg_bytes) {
  stereo_pair_t p{};
  p.kind = stereo_pair_t::KIND_PAIR;
  p.panorama = "pano";
  p.has_right = true;
  p.left.stem = std::string(stem_chars, 'L');
  p.right.stem = "right";
  p.left.jpeg.assign(static_cast<std::size_t>(jpeg_bytes), 7);
  p.left.jpeg_bytes = jpeg_bytes;
  p.right.jpeg.assign(10, 1);
  p.right.jpeg_bytes = 10;
  return p;
}

}  // namespace

TEST_GROUP(MessageAdapters){};

// CameraModel -> camera_model_t -> CameraModel is exact; bad models get their status and the component.
TEST(MessageAdapters, CameraModelRoundTripAndBadModels) {
  const CameraModel in = cahvor();
  camera_model_t msg{};
  toMessage(in, msg);
  CameraModel out;
  const char* field = "";
  CHECK_EQUAL(static_cast<int>(Status::kOk), static_cast<int>(toCameraModel(msg, out, field)));
  CHECK_TRUE(out.c == in.c && out.a == in.a && out.h == in.h && out.v == in.v && out.o == in.o &&
             out.r == in.r);
  CHECK_EQUAL(in.width, out.width);
  CHECK_TRUE(out.type == CameraType::kCahvor);

  camera_model_t nan = msg;
  nan.v_px[1] = std::numeric_limits<double>::quiet_NaN();
  CHECK_EQUAL(static_cast<int>(Status::kNotFinite), static_cast<int>(toCameraModel(nan, out, field)));
  STRCMP_EQUAL("V", field);
  camera_model_t bad_type = msg;
  bad_type.type = camera_model_t::TYPE_INVALID;
  CHECK_EQUAL(static_cast<int>(Status::kUnsupported), static_cast<int>(toCameraModel(bad_type, out, field)));
  camera_model_t parallel = msg;
  for (int k = 0; k < 3; ++k) parallel.h_px[k] = 100.0 * parallel.a[k];  // H parallel to A
  CHECK_EQUAL(static_cast<int>(Status::kInvalidArgument),
              static_cast<int>(toCameraModel(parallel, out, field)));
}

// The capacity walk accepts a pair within the reserved sizes, names the field that is too large, and a
// prepared message then decodes without heap.
TEST(MessageAdapters, CapacityWalkAndHeapFreeDecode) {
  const char* field = "";
  const std::vector<uint8_t> good = encode(pairWith(20, 5000));
  CHECK_EQUAL(static_cast<int>(Status::kOk),
              static_cast<int>(checkStereoPairCapacity(good.data(), good.size(), field)));
  const std::vector<uint8_t> long_stem = encode(pairWith(kMaxMessageStringChars + 1, 10));
  CHECK_EQUAL(static_cast<int>(Status::kCapacityExceeded),
              static_cast<int>(checkStereoPairCapacity(long_stem.data(), long_stem.size(), field)));
  STRCMP_EQUAL("left.stem", field);
  const std::vector<uint8_t> big = encode(pairWith(4, kMaxJpegBytes + 1));
  CHECK_EQUAL(static_cast<int>(Status::kCapacityExceeded),
              static_cast<int>(checkStereoPairCapacity(big.data(), big.size(), field)));
  STRCMP_EQUAL("left.jpeg_bytes", field);
  CHECK_EQUAL(static_cast<int>(Status::kTruncated),
              static_cast<int>(checkStereoPairCapacity(good.data(), 40, field)));

  stereo_pair_t received;
  prepareStereoPair(received);
  const std::vector<uint8_t> full = encode(pairWith(kMaxMessageStringChars, kMaxJpegBytes));
  areomap::HeapAllocationScope scope;
  CHECK_EQUAL(static_cast<int>(Status::kOk),
              static_cast<int>(checkStereoPairCapacity(full.data(), full.size(), field)));
  CHECK_EQUAL(static_cast<int>(Status::kOk),
              static_cast<int>(msgs::decodeMessage(full.data(), full.size(), received)));
  CHECK_EQUAL(static_cast<int>(Status::kOk),
              static_cast<int>(msgs::decodeMessage(good.data(), good.size(), received)));
  CHECK_EQUAL(0u, scope.allocations());
  CHECK_EQUAL(5000, received.left.jpeg_bytes);
  CHECK_EQUAL(encodedFingerprint(good.data(), good.size()), static_cast<uint64_t>(stereo_pair_t::getHash()));
}

// kMaxStereoPairMessageBytes is the encoded size of the largest pair the capacity check accepts (every string
// at kMaxMessageStringChars, both JPEGs at kMaxJpegBytes), as the generated encoder counts it; a character
// more is refused.
TEST(MessageAdapters, LargestAcceptedPairIsTheStatedSize) {
  stereo_pair_t p = pairWith(kMaxMessageStringChars, kMaxJpegBytes);
  p.panorama = std::string(kMaxMessageStringChars, 'P');
  p.right.stem = std::string(kMaxMessageStringChars, 'R');
  p.right.jpeg.assign(static_cast<std::size_t>(kMaxJpegBytes), 3);
  p.right.jpeg_bytes = kMaxJpegBytes;
  const std::vector<uint8_t> largest = encode(p);
  CHECK_EQUAL(kMaxStereoPairMessageBytes, largest.size());
  const char* field = "";
  CHECK_EQUAL(static_cast<int>(Status::kOk),
              static_cast<int>(checkStereoPairCapacity(largest.data(), largest.size(), field)));
  p.panorama.push_back('P');
  const std::vector<uint8_t> beyond = encode(p);
  CHECK_EQUAL(static_cast<int>(Status::kCapacityExceeded),
              static_cast<int>(checkStereoPairCapacity(beyond.data(), beyond.size(), field)));
  STRCMP_EQUAL("panorama", field);
}

// Sizes read from a message are checked against the capacities before anything is decoded: the JPEG is
// present, the image is 1..kMaxBinnedSourceWidth x 1..kMaxBinnedSourceHeight (beyond the capacity as far as
// binning by at most kMaxBinning reaches: the rover bins it; one pixel more on either side is refused), the
// model is of the image's size.
TEST(MessageAdapters, ImageSizesCheckedAgainstCapacities) {
  stereo_image_t side{};
  side.jpeg_bytes = 100;
  side.width_px = 1024;
  side.height_px = 768;
  side.model.width_px = 1024;
  side.model.height_px = 768;
  const char* field = "";
  CHECK_EQUAL(static_cast<int>(Status::kOk), static_cast<int>(checkImageSizes(side, field)));
  struct Case {
    int32_t jpeg, width, height, model_width, model_height;
    Status status;
    const char* field;
  };
  const Case cases[] = {
      {0, 1024, 768, 1024, 768, Status::kMissingField, "jpeg_bytes"},
      {-5, 1024, 768, 1024, 768, Status::kMissingField, "jpeg_bytes"},
      // Above the capacity but within kMaxBinning of it: binned by the rover, so accepted here (kOk).
      {100, kMaxImageWidth + 1, 768, kMaxImageWidth + 1, 768, Status::kOk, ""},
      {100, 5120, 3840, 5120, 3840, Status::kOk, ""},
      {100, kMaxBinnedSourceWidth, kMaxBinnedSourceHeight, kMaxBinnedSourceWidth, kMaxBinnedSourceHeight,
       Status::kOk, ""},
      {100, kMaxBinnedSourceWidth + 1, 768, kMaxBinnedSourceWidth + 1, 768, Status::kCapacityExceeded,
       "width_px"},
      {100, 1024, kMaxBinnedSourceHeight + 1, 1024, kMaxBinnedSourceHeight + 1, Status::kCapacityExceeded,
       "height_px"},
      {100, 0, 768, 0, 768, Status::kInvalidArgument, "width_px"},
      {100, 1024, -1, 1024, -1, Status::kInvalidArgument, "height_px"},
      {100, 1024, 768, 2048, 768, Status::kInvalidArgument, "model.width_px"},
      {100, 1024, 768, 1024, 0, Status::kInvalidArgument, "model.height_px"},
      {100, INT32_MIN, 768, 1024, 768, Status::kInvalidArgument, "width_px"},
      {100, INT32_MAX, 768, 1024, 768, Status::kCapacityExceeded, "width_px"},
  };
  for (const Case& c : cases) {
    stereo_image_t bad = side;
    bad.jpeg_bytes = c.jpeg;
    bad.width_px = c.width;
    bad.height_px = c.height;
    bad.model.width_px = c.model_width;
    bad.model.height_px = c.model_height;
    CHECK_EQUAL(static_cast<int>(c.status), static_cast<int>(checkImageSizes(bad, field)));
    STRCMP_EQUAL(c.field, field);
  }
}

// The tie plan: the announced pair count within 1..kMaxPairs, else the capacity.
TEST(MessageAdapters, PlannedPairsWithinCapacity) {
  CHECK_EQUAL(8, plannedPairs(8));
  CHECK_EQUAL(1, plannedPairs(1));
  CHECK_EQUAL(kMaxPairs, plannedPairs(kMaxPairs));
  CHECK_EQUAL(kMaxPairs, plannedPairs(kMaxPairs + 1));
  CHECK_EQUAL(kMaxPairs, plannedPairs(-1));
  CHECK_EQUAL(kMaxPairs, plannedPairs(0));
  CHECK_EQUAL(kMaxPairs, plannedPairs(INT32_MIN));
  CHECK_EQUAL(kMaxPairs, plannedPairs(INT32_MAX));
}

namespace {

site_t goodSite(int32_t index, int32_t planned) {
  return test::makeSite(index, planned);
}

std::vector<uint8_t> encodeSite(const site_t& s) {
  std::vector<uint8_t> b(static_cast<std::size_t>(s.getEncodedSize()));
  CHECK_EQUAL(static_cast<int>(b.size()), s.encode(b.data(), 0, static_cast<int>(b.size())));
  return b;
}

// decodeSite's status and field for a site_t changed by `change`.
template <class Change>
void expectSite(Status expected, const char* expected_field, Change change) {
  site_t s = goodSite(1, 3);
  change(s);
  const std::vector<uint8_t> bytes = encodeSite(s);
  site_t out;
  prepareSite(out);
  const char* field = "";
  CHECK_EQUAL(static_cast<int>(expected),
              static_cast<int>(decodeSite(bytes.data(), bytes.size(), out, field)));
  STRCMP_EQUAL(expected_field, field);
}

}  // namespace

// A site announcement (AREOMAP_SITE): the encoding checked, strings within the reserved capacity before the
// decode (no heap), then the content a traverse needs; each refusal names its field.
TEST(MessageAdapters, SiteAnnouncementChecked) {
  site_t out;
  prepareSite(out);
  const char* field = "";
  for (int32_t k = 0; k < 3; ++k) {
    const std::vector<uint8_t> bytes = encodeSite(goodSite(k, 3));
    areomap::HeapAllocationScope scope;
    CHECK_EQUAL(static_cast<int>(Status::kOk),
                static_cast<int>(decodeSite(bytes.data(), bytes.size(), out, field)));
    CHECK_EQUAL(0u, scope.allocations());
    CHECK_EQUAL(k, out.site_index);
  }
  const std::vector<uint8_t> good = encodeSite(goodSite(1, 3));
  CHECK_EQUAL(static_cast<int>(Status::kTruncated),
              static_cast<int>(decodeSite(good.data(), good.size() / 2, out, field)));
  STRCMP_EQUAL("encoding", field);
  const std::vector<uint8_t> pair = encode(pairWith(4, 10));
  CHECK_EQUAL(static_cast<int>(Status::kCorruptData),
              static_cast<int>(decodeSite(pair.data(), pair.size(), out, field)));
  // Longest string: reported by checkEncoding, refused before decode() would grow the reserved string.
  site_t long_name = goodSite(1, 3);
  long_name.traverse = std::string(kMaxMessageStringChars + 1, 't');
  const std::vector<uint8_t> long_bytes = encodeSite(long_name);
  int64_t longest = 0;
  CHECK_EQUAL(
      static_cast<int>(Status::kOk),
      static_cast<int>(msgs::checkEncoding(site_t::getTypeName(), static_cast<uint64_t>(site_t::getHash()),
                                           long_bytes.data(), long_bytes.size(), longest)));
  CHECK_EQUAL(kMaxMessageStringChars + 1, longest);
  const std::size_t capacity = out.traverse.capacity();
  CHECK_EQUAL(static_cast<int>(Status::kCapacityExceeded),
              static_cast<int>(decodeSite(long_bytes.data(), long_bytes.size(), out, field)));
  CHECK_EQUAL(capacity, out.traverse.capacity());

  expectSite(Status::kInvalidArgument, "site_id", [](site_t& s) { s.site_id = "site/02"; });
  expectSite(Status::kMissingField, "panorama", [](site_t& s) { s.panorama = ""; });
  expectSite(Status::kInvalidArgument, "kind", [](site_t& s) { s.kind = 2; });
  expectSite(Status::kOk, "", [](site_t& s) { s.kind = site_t::KIND_STOP; });
  expectSite(Status::kInvalidArgument, "sites_planned", [](site_t& s) { s.sites_planned = 0; });
  expectSite(Status::kInvalidArgument, "site_index", [](site_t& s) { s.site_index = 3; });
  expectSite(Status::kInvalidArgument, "is_last", [](site_t& s) { s.is_last = true; });
  expectSite(Status::kNotFinite, "position_m/heading_deg",
             [](site_t& s) { s.position_m[1] = std::numeric_limits<double>::quiet_NaN(); });
  expectSite(Status::kMissingField, "has_odometry", [](site_t& s) { s.has_odometry = false; });
  expectSite(Status::kInvalidArgument, "odometry_from", [](site_t& s) { s.odometry_from = s.site_id; });
  expectSite(Status::kNotFinite, "odometry",
             [](site_t& s) { s.delta_m[2] = std::numeric_limits<double>::infinity(); });
  expectSite(Status::kInvalidArgument, "sigma_m/sigma_heading_deg", [](site_t& s) { s.sigma_m[0] = 0.0; });
  expectSite(Status::kInvalidArgument, "distance_m", [](site_t& s) { s.distance_m = -1.0; });
  expectSite(Status::kInvalidArgument, "has_odometry", [](site_t& s) {
    s.site_index = 0;
    s.has_odometry = true;
  });
}
