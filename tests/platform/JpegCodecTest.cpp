#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "firmware_core/base/Capacities.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "platform/posix/TurboJpegCodec.hpp"

#include <CppUTest/TestHarness.h>

using areomap::Status;
using areomap::platform::TurboJpegCodec;

namespace {

int code(Status s) {
  return static_cast<int>(s);
}

// The rover's image buffer: static, sized by the capacity.
uint8_t g_image[areomap::kMaxImagePixels];

// A textured 1024x1024 test image (smooth relief + fine texture), the synthetic truth.
std::vector<uint8_t> makeImage(int width, int height) {
  std::vector<uint8_t> pixels(static_cast<std::size_t>(width) * height);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double v =
          128.0 + 60.0 * std::sin(x * 0.031) * std::cos(y * 0.017) + 25.0 * std::sin((x + 2 * y) * 0.21);
      pixels[static_cast<std::size_t>(y) * width + x] = static_cast<uint8_t>(std::lround(v));
    }
  }
  return pixels;
}

struct Fixture {
  TurboJpegCodec codec;
  std::vector<uint8_t> truth;
  std::vector<uint8_t> jpeg;
};

void encodeTruth(Fixture& f, int width, int height, int quality) {
  CHECK(ok(f.codec.open()));
  f.truth = makeImage(width, height);
  f.jpeg.resize(f.codec.maxEncodedBytes(width, height));
  std::size_t bytes = 0;
  CHECK(ok(f.codec.encodeGray(f.truth.data(), width, height, quality, f.jpeg.data(), f.jpeg.size(), bytes)));
  f.jpeg.resize(bytes);
}

}  // namespace

TEST_GROUP(JpegCodec){};

TEST(JpegCodec, Decodes1024SquareIntoStaticBuffer) {
  Fixture f;
  encodeTruth(f, 1024, 1024, 95);
  int32_t width = 0;
  int32_t height = 0;
  Status status = Status::kCount;
  uint64_t allocations = 0;
  {
    areomap::HeapAllocationScope scope;
    status = f.codec.decodeGray(f.jpeg.data(), f.jpeg.size(), g_image, sizeof(g_image), width, height);
    allocations = scope.allocations();
  }
  CHECK_EQUAL(code(Status::kOk), code(status));
  CHECK_EQUAL(1024, width);
  CHECK_EQUAL(1024, height);
  double sum = 0.0;
  int worst = 0;
  for (std::size_t i = 0; i < f.truth.size(); ++i) {
    const int d = std::abs(static_cast<int>(g_image[i]) - static_cast<int>(f.truth[i]));
    sum += d;
    worst = d > worst ? d : worst;
  }
  const double mean = sum / static_cast<double>(f.truth.size());
  std::printf(
      "1024x1024 quality 95: %zu JPEG bytes, decoded mean |error| %.3f, max %d grey levels; "
      "heap allocations inside one decode (libjpeg pools): %llu\n",
      f.jpeg.size(), mean, worst, static_cast<unsigned long long>(allocations));
  // Tolerance: quality-95 JPEG of this texture stays within ~1 grey level on average, a few at worst.
  CHECK(mean < 1.5);
  CHECK(worst <= 12);
}

TEST(JpegCodec, OverCapacityIsRefusedBeforeDecoding) {
  Fixture f;
  encodeTruth(f, 1024, 1024, 90);
  int32_t width = 0;
  int32_t height = 0;
  g_image[512 * 512] = 77;
  CHECK_EQUAL(code(Status::kCapacityExceeded),
              code(f.codec.decodeGray(f.jpeg.data(), f.jpeg.size(), g_image, 512 * 512, width, height)));
  CHECK_EQUAL(1024, width);  // the header's size is reported
  CHECK_EQUAL(1024, height);
  CHECK_EQUAL(77, g_image[512 * 512]);  // nothing written beyond the capacity
}

TEST(JpegCodec, TruncatedJpegsGiveTruncated) {
  Fixture f;
  encodeTruth(f, 256, 256, 90);
  int32_t width = 0;
  int32_t height = 0;
  const std::size_t cuts[] = {2, 100, f.jpeg.size() / 2, f.jpeg.size() - 2};
  for (std::size_t cut : cuts) {
    const Status s = f.codec.decodeGray(f.jpeg.data(), cut, g_image, sizeof(g_image), width, height);
    std::printf("cut at %zu of %zu bytes: %s (%s)\n", cut, f.jpeg.size(), areomap::statusName(s),
                f.codec.lastError());
    CHECK_EQUAL(code(Status::kTruncated), code(s));
  }
}

TEST(JpegCodec, CorruptJpegsGiveCorruptData) {
  Fixture f;
  encodeTruth(f, 256, 256, 90);
  int32_t width = 0;
  int32_t height = 0;
  // Not a JPEG at all.
  std::vector<uint8_t> garbage(5000, 0x5A);
  CHECK_EQUAL(code(Status::kCorruptData), code(f.codec.decodeGray(garbage.data(), garbage.size(), g_image,
                                                                  sizeof(g_image), width, height)));
  // A damaged frame header: the SOF0 segment's sample precision set to 99 bits.
  std::vector<uint8_t> bad = f.jpeg;
  std::size_t sof = 0;
  for (std::size_t i = 2; i + 1 < bad.size() && sof == 0; ++i) {
    if (bad[i] == 0xFF && bad[i + 1] == 0xC0) sof = i;
  }
  CHECK(sof > 0);
  bad[sof + 4] = 99;
  Status s = f.codec.decodeGray(bad.data(), bad.size(), g_image, sizeof(g_image), width, height);
  std::printf("bad SOF precision: %s (%s)\n", areomap::statusName(s), f.codec.lastError());
  CHECK_EQUAL(code(Status::kCorruptData), code(s));
  // Damaged entropy-coded data: a stray marker in the middle of the scan.
  bad = f.jpeg;
  const std::size_t middle = bad.size() / 2;
  for (std::size_t i = 0; i < 64; i += 2) {
    bad[middle + i] = 0xFF;
    bad[middle + i + 1] = 0xD3;  // a restart marker where none is expected
  }
  s = f.codec.decodeGray(bad.data(), bad.size(), g_image, sizeof(g_image), width, height);
  std::printf("stray markers in the scan: %s (%s)\n", areomap::statusName(s), f.codec.lastError());
  CHECK_EQUAL(code(Status::kCorruptData), code(s));
  // Null pointers and a too-small encode buffer.
  CHECK_EQUAL(code(Status::kInvalidArgument),
              code(f.codec.decodeGray(nullptr, 10, g_image, sizeof(g_image), width, height)));
  std::size_t bytes = 0;
  CHECK_EQUAL(code(Status::kCapacityExceeded),
              code(f.codec.encodeGray(f.truth.data(), 256, 256, 90, g_image, 1000, bytes)));
}

TEST(JpegCodec, UnopenedCodecSaysUnsupported) {
  TurboJpegCodec codec;
  int32_t width = 0;
  int32_t height = 0;
  const uint8_t soi[] = {0xFF, 0xD8, 0xFF, 0xD9};
  CHECK_EQUAL(code(Status::kUnsupported),
              code(codec.decodeGray(soi, sizeof(soi), g_image, 16, width, height)));
}
