// firmware_core/base/LineBinner.hpp: binning line by line against the b x b block means computed directly.
#include <cstdint>
#include <vector>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/LineBinner.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

LineBinner g_binner;  // the sums array: static, as in the decoder's arena

uint8_t pixelAt(int32_t x, int32_t y) {
  return static_cast<uint8_t>((x * 37 + y * 101 + (x * y) % 13) & 0xFF);
}

}  // namespace

TEST_GROUP(LineBinner){};

// Odd sizes (the last width mod b columns and height mod b lines left out), every factor, rounding half up.
TEST(LineBinner, BlockMeansOfEveryFactor) {
  const int32_t width = 1037, height = 83;
  std::vector<uint8_t> line(static_cast<std::size_t>(width));
  for (int32_t b = 1; b <= kMaxBinning; ++b) {
    std::vector<uint8_t> out(static_cast<std::size_t>((width / b) * (height / b)), 0);
    if (b == 1) {
      CHECK_FALSE(g_binner.begin(width, height, b, out.data(), out.size()));  // 1037 > kMaxImageWidth
      continue;
    }
    CHECK(g_binner.begin(width, height, b, out.data(), out.size()));
    LONGS_EQUAL(width / b, g_binner.binnedWidth());
    LONGS_EQUAL(height / b, g_binner.binnedHeight());
    for (int32_t y = 0; y < height; ++y) {
      for (int32_t x = 0; x < width; ++x) line[static_cast<std::size_t>(x)] = pixelAt(x, y);
      g_binner.addLine(line.data());
    }
    for (int32_t yb = 0; yb < height / b; ++yb) {
      for (int32_t xb = 0; xb < width / b; ++xb) {
        int32_t sum = 0;
        for (int32_t dy = 0; dy < b; ++dy)
          for (int32_t dx = 0; dx < b; ++dx) sum += pixelAt(xb * b + dx, yb * b + dy);
        const int32_t n = b * b;
        const int32_t expected = (2 * sum + n) / (2 * n);  // round half up
        LONGS_EQUAL(expected, out[static_cast<std::size_t>(yb * (width / b) + xb)]);
      }
    }
  }
}

// Refusals: a factor outside 1..kMaxBinning, a binned image beyond the buffer or beyond kMaxImageWidth.
TEST(LineBinner, RefusesWhatDoesNotFit) {
  uint8_t out[16];
  CHECK_FALSE(g_binner.begin(8, 8, 0, out, sizeof(out)));
  CHECK_FALSE(g_binner.begin(8, 8, kMaxBinning + 1, out, sizeof(out)));
  CHECK_FALSE(g_binner.begin(10, 10, 2, out, sizeof(out)));  // 5 x 5 = 25 > 16
  CHECK(g_binner.begin(9, 9, 2, out, sizeof(out)));          // 4 x 4
  CHECK_FALSE(g_binner.begin(2 * (kMaxImageWidth + 1), 2, 2, out, sizeof(out)));
  CHECK_FALSE(g_binner.begin(1, 8, 2, out, sizeof(out)));  // no whole block
  CHECK_FALSE(g_binner.begin(8, 8, 2, nullptr, 16));
}
