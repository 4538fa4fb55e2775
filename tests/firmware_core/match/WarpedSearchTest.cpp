// The warped window search of firmware_core/match/WarpedSearch.hpp: its four-centre blocks give
// nccWarpedAt's score at every centre bit for bit (against searchWindowWarpedDirect, near the image
// borders too), and nccWarpedAt's shared sample grid is the bilinear NCC at centre + a * (u, v) computed
// independently here.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

#include "firmware_core/match/VectorKernels.hpp"
#include "firmware_core/match/WarpedSearch.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

std::vector<uint8_t> smoothNoise(int32_t w, int32_t h, int32_t stride, std::mt19937& rng) {
  std::vector<uint8_t> pixels(static_cast<size_t>(stride) * h);
  std::uniform_int_distribution<int> grey(0, 255);
  for (auto& p : pixels) p = static_cast<uint8_t>(grey(rng));
  for (int32_t y = 0; y < h; ++y) {
    for (int32_t x = 1; x < w; ++x) {
      pixels[y * stride + x] =
          static_cast<uint8_t>((pixels[y * stride + x] + pixels[y * stride + x - 1]) / 2);
    }
  }
  return pixels;
}

// The bilinear NCC at centre + a * (u, v), each sample position computed on its own.
double independentWarpedNcc(const NccTemplate& t, const ImageView& image, int32_t cx, int32_t cy,
                            const Mat2& a) {
  std::vector<double> ts, ws;
  for (int32_t v = -kNccRadius; v <= kNccRadius; ++v) {
    for (int32_t u = -kNccRadius; u <= kNccRadius; ++u) {
      const double x = cx + a(0, 0) * u + a(0, 1) * v;
      const double y = cy + a(1, 0) * u + a(1, 1) * v;
      const int32_t x0 = static_cast<int32_t>(std::floor(x)), y0 = static_cast<int32_t>(std::floor(y));
      const double fx = x - x0, fy = y - y0;
      ws.push_back((1 - fx) * (1 - fy) * image.at(x0, y0) + fx * (1 - fy) * image.at(x0 + 1, y0) +
                   (1 - fx) * fy * image.at(x0, y0 + 1) + fx * fy * image.at(x0 + 1, y0 + 1));
      ts.push_back(t.pixels[(v + kNccRadius) * kNccSide + (u + kNccRadius)]);
    }
  }
  return nccOfSamples(ts.data(), ws.data(), kNccPixels, 0.0);
}

}  // namespace

TEST_GROUP(WarpedSearch){};

TEST(WarpedSearch, FourCentreBlocksEqualNccWarpedAtBitForBit) {
  const int32_t w = 260, h = 200, stride = 272;
  std::mt19937 rng(23);
  const std::vector<uint8_t> pixels = smoothNoise(w, h, stride, rng);
  const ImageView image{pixels.data(), w, h, stride};
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> coin(0, 3);
  static WarpedSearchScratch scratch;
  int32_t found = 0, clipped = 0;
  for (int32_t trial = 0; trial < 80; ++trial) {
    NccTemplate t;
    CHECK(extractTemplate(image, 20 + static_cast<int32_t>(unit(rng) * 220),
                          20 + static_cast<int32_t>(unit(rng) * 160), t));
    // Identity, then rotations, scales and shears of the patch.
    Mat2 a = Mat2::Identity();
    if (trial > 0) {
      const double angle = (unit(rng) - 0.5) * 1.2, scale = 0.7 + 0.8 * unit(rng),
                   shear = (unit(rng) - 0.5) * 0.6;
      a << scale * std::cos(angle), -scale * std::sin(angle) + shear, scale * std::sin(angle),
          scale * std::cos(angle);
    }
    // Centres anywhere, also where the window leaves the image (rows and columns cut off at every border).
    const int32_t cx = static_cast<int32_t>(unit(rng) * w), cy = static_cast<int32_t>(unit(rng) * h);
    const int32_t radius =
        coin(rng) == 0 ? kInterOffsetSearchRadiusPx : 1 + static_cast<int32_t>(unit(rng) * 20);
    const SearchHit direct = searchWindowWarpedDirect(t, image, cx, cy, radius, a);
    // The baseline kernels, then the AVX2 ones where the processor has them (VectorKernels.hpp).
    for (const bool avx2 : {false, true}) {
      allowMatchAvx2(avx2);
      const SearchHit fast = searchWindowWarped(t, image, cx, cy, radius, a, scratch);
      CHECK_EQUAL(direct.score, fast.score);
      CHECK_EQUAL(direct.second, fast.second);
      CHECK_EQUAL(direct.x, fast.x);
      CHECK_EQUAL(direct.y, fast.y);
    }
    found += direct.score > kNccInvalid ? 1 : 0;
    clipped += cx < radius + 10 || cy < radius + 10 || cx > w - radius - 10 || cy > h - radius - 10 ? 1 : 0;
  }
  std::printf("warped search: %d of 80 searches found a score, equal to nccWarpedAt's (AVX2 kernels %s)\n",
              found, matchUsesAvx2() ? "compared too" : "not on this processor");
  CHECK(found >= 60);
  CHECK(clipped >= 20);
}

TEST(WarpedSearch, NccWarpedAtIsTheBilinearNccOfTheWarpedWindow) {
  const int32_t w = 120, h = 100;
  std::mt19937 rng(29);
  const std::vector<uint8_t> pixels = smoothNoise(w, h, w, rng);
  const ImageView image{pixels.data(), w, h, w};
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int32_t compared = 0;
  for (int32_t trial = 0; trial < 60; ++trial) {
    NccTemplate t;
    CHECK(extractTemplate(image, 30 + trial % 50, 25 + trial % 40, t));
    Mat2 a;
    a << 0.6 + unit(rng), unit(rng) - 0.5, unit(rng) - 0.5, 0.6 + unit(rng);
    const int32_t cx = 25 + static_cast<int32_t>(unit(rng) * 70),
                  cy = 25 + static_cast<int32_t>(unit(rng) * 50);
    const double got = nccWarpedAt(t, image, cx, cy, a);
    const double expected = independentWarpedNcc(t, image, cx, cy, a);
    if (got == kNccInvalid) continue;
    DOUBLES_EQUAL(expected, got, 1e-12);
    ++compared;
  }
  CHECK(compared >= 50);
  // The identity map samples the pixels themselves: nccAt's score exactly.
  NccTemplate t;
  CHECK(extractTemplate(image, 40, 40, t));
  CHECK_EQUAL(nccAt(t, image, 52, 47), nccWarpedAt(t, image, 52, 47, Mat2::Identity()));
}
