// The NCC of firmware_core/match/Ncc.hpp: nccOfSamples (the ground's warped patches) and nccAt (the rover's
// 8-bit template) are one formula, equal bit for bit on the same samples; the flat-window floor of
// nccOfSamples holds at and below its min_variance.
#include <cstdint>
#include <random>
#include <vector>

#include "firmware_core/match/Ncc.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

TEST_GROUP(Ncc){};

TEST(Ncc, SamplesAndTemplateGiveTheSameNccBitForBit) {
  constexpr int32_t kWidth = 40, kHeight = 30;
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> grey(0, 255);
  std::vector<uint8_t> pixels(kWidth * kHeight);
  int compared = 0;
  for (int trial = 0; trial < 50; ++trial) {
    for (uint8_t& p : pixels) p = static_cast<uint8_t>(grey(rng));
    const ImageView image{pixels.data(), kWidth, kHeight, kWidth};
    NccTemplate t;
    CHECK_TRUE(extractTemplate(image, 8, 8, t));
    const int32_t cx = 12 + trial % 20, cy = 8 + trial % 14;
    std::vector<double> ts(kNccPixels), ws(kNccPixels);
    for (int32_t k = 0; k < kNccPixels; ++k) {
      ts[k] = t.pixels[k];
      ws[k] = image.row(cy - kNccRadius + k / kNccSide)[cx - kNccRadius + k % kNccSide];
    }
    const double expected = nccAt(t, image, cx, cy);
    if (expected == kNccInvalid) continue;
    CHECK_EQUAL(expected, nccOfSamples(ts.data(), ws.data(), kNccPixels, 0.0));
    ++compared;
  }
  CHECK(compared > 40);
}

TEST(Ncc, SamplesAtOrBelowTheVarianceFloorHaveNoNcc) {
  // Two samples 0 and 1: n * sum_sq - sum^2 = 2 * 1 - 1 = 1.
  const double t[] = {0.0, 1.0};
  const double s[] = {5.0, 6.0};
  const double flat[] = {3.0, 3.0};
  CHECK_EQUAL(kNccInvalid, nccOfSamples(t, s, 2, 1.0));
  DOUBLES_EQUAL(1.0, nccOfSamples(t, s, 2, 0.999), 1e-15);
  CHECK_EQUAL(kNccInvalid, nccOfSamples(t, flat, 2, 0.0));
  CHECK_EQUAL(kNccInvalid, nccOfSamples(flat, s, 2, 0.0));
  const double reversed[] = {6.0, 5.0};
  DOUBLES_EQUAL(-1.0, nccOfSamples(t, reversed, 2, 0.5), 1e-15);
}
