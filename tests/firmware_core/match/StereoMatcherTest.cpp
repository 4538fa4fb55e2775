#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "firmware_core/match/StereoMatcher.hpp"
#include "firmware_core/match/VectorKernels.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/match/SyntheticStereo.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

StereoWorkspace g_stereo;  // ~9 MiB: static, as on the rover
StereoResult g_result;

// Distance of a tie's right observation from the truth: the left pixel's ray meets the ground plane and
// that point is projected into the right camera.
double truthError(const test::StereoScene& scene, const StereoMatch& m) {
  Vec3 p;
  Vec2 truth;
  if (!test::groundPoint(scene.left, m.left_px, p) || project(scene.right, p, truth) != Status::kOk) return 1e9;
  return (m.right_px - truth).norm();
}

}  // namespace

TEST_GROUP(StereoMatcher){};

TEST(StereoMatcher, TiesAreWithinAPixelOfTheTruthAndSpreadOverTheImage) {
  const test::StereoScene scene = test::makeStereoScene(384);
  StereoParams params;
  params.grid_cell_px = 32;
  HeapAllocationScope scope;
  const Status s = matchStereoPair(scene.leftView(), scene.rightView(), scene.left, scene.right, params, g_stereo,
                                   g_result);
  CHECK_EQUAL(0u, scope.allocations());
#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
  CHECK(heapCounterActive());  // the zero above is a count, not an absent counter (sanitizers own malloc)
#endif
  CHECK_EQUAL(static_cast<int>(Status::kOk), static_cast<int>(s));
  int32_t within = 0;
  double sum_sq = 0.0, worst = 0.0;
  for (int32_t i = 0; i < g_result.tie_count; ++i) {
    const double e = truthError(scene, g_result.ties[i]);
    within += e <= 1.0 ? 1 : 0;
    sum_sq += e * e;
    worst = std::fmax(worst, e);
  }
  const StereoCounts& c = g_result.counts;
  std::printf("intra: %d interest, %d searched, %d ncc, %d lr, %d parallax, %d selected; within 1 px %d (%.1f %%), "
              "rms %.3f px, worst %.2f px; parallax sigma %.2f px\n",
              c.interest_points, c.searched, c.ncc_passed, c.lr_passed, c.parallax_passed, c.selected, within,
              100.0 * within / std::max(1, g_result.tie_count), std::sqrt(sum_sq / std::max(1, g_result.tie_count)),
              worst, g_result.curve.sigma_px);
  CHECK(g_result.tie_count >= 100);  // 12 x 12 cells of 32 px
  CHECK(within >= 0.98 * g_result.tie_count);
  // At most one tie per cell.
  std::vector<int> cells(144, 0);
  for (int32_t i = 0; i < g_result.tie_count; ++i) {
    const int cell = int(g_result.ties[i].left_px.y()) / 32 * 12 + int(g_result.ties[i].left_px.x()) / 32;
    CHECK(++cells[cell] == 1);
  }
}

TEST(StereoMatcher, AprioriPointingErrorsOfAFewPixelsAreAbsorbedByTheBand) {
  const test::StereoScene scene = test::makeStereoScene(256, 0.3, 0.7, 11);
  // The a-priori right model is off by a rotation of ~7 mrad (~2 px at f = 309 px).
  CameraModel apriori = movedModel(scene.right, rotationFromVector(Vec3(0.004, 0.0, 0.006)), scene.right.c);
  StereoParams params;
  params.grid_cell_px = 32;
  const Status s = matchStereoPair(scene.leftView(), scene.rightView(), scene.left, apriori, params, g_stereo,
                                   g_result);
  CHECK_EQUAL(static_cast<int>(Status::kOk), static_cast<int>(s));
  int32_t within = 0;
  for (int32_t i = 0; i < g_result.tie_count; ++i) within += truthError(scene, g_result.ties[i]) <= 1.0 ? 1 : 0;
  std::printf("intra with pointing error: %d selected, %d within 1 px of truth\n", g_result.tie_count, within);
  CHECK(g_result.tie_count >= 40);
  CHECK(within >= 0.98 * g_result.tie_count);
}

TEST(StereoMatcher, BlankSaturatedAndNoiseOnlyPairsHaveNoTexture) {
  const int32_t n = 256;
  std::vector<uint8_t> a(n * n), b(n * n);
  const test::StereoScene scene = test::makeStereoScene(n);
  StereoParams params;
  const ImageView va{a.data(), n, n, n}, vb{b.data(), n, n, n};
  for (uint8_t value : {uint8_t(0), uint8_t(255)}) {
    std::fill(a.begin(), a.end(), value);
    std::fill(b.begin(), b.end(), value);
    const Status s = matchStereoPair(va, vb, scene.left, scene.right, params, g_stereo, g_result);
    CHECK_EQUAL(static_cast<int>(Status::kNoTexture), static_cast<int>(s));
    CHECK_EQUAL(0, g_result.tie_count);
  }
  // Independent noise in the two images: plenty of interest points, but nothing may match.
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> dist(0, 255);
  for (auto& p : a) p = static_cast<uint8_t>(dist(rng));
  for (auto& p : b) p = static_cast<uint8_t>(dist(rng));
  HeapAllocationScope scope;
  const Status s = matchStereoPair(va, vb, scene.left, scene.right, params, g_stereo, g_result);
  CHECK_EQUAL(0u, scope.allocations());
  std::printf("noise pair: %s, %d interest points, %d passed NCC, %d selected\n", statusName(s),
              g_result.counts.interest_points, g_result.counts.ncc_passed, g_result.tie_count);
  CHECK_EQUAL(static_cast<int>(Status::kNoTexture), static_cast<int>(s));
  // A textured left image against a blank right one: also no texture, no bogus ties.
  std::fill(b.begin(), b.end(), 90);
  const Status s2 = matchStereoPair(scene.leftView(), vb, scene.left, scene.right, params, g_stereo, g_result);
  CHECK_EQUAL(static_cast<int>(Status::kNoTexture), static_cast<int>(s2));
}

TEST_GROUP(CurveSearch){};

// The line-wise search (scores a line at a time in float vectors, then read in the search order) equals the
// position-by-position one (nccAt everywhere): best score and position, and the second peak, on random
// textures and templates, along curves of every direction, partly outside the image, with a stride wider
// than the image, and with a band beyond the scratch (the fallback).
TEST(CurveSearch, LineWiseSearchEqualsNccAtEveryPosition) {
  const int32_t w = 300, h = 220, stride = 320;
  std::vector<uint8_t> pixels(static_cast<size_t>(stride) * h);
  std::mt19937 rng(17);
  std::uniform_int_distribution<int> grey(0, 255);
  for (auto& p : pixels) p = static_cast<uint8_t>(grey(rng));
  // Smooth it a little so that neighbouring scores differ by small amounts (near-ties and second peaks).
  for (int32_t y = 0; y < h; ++y) {
    for (int32_t x = 1; x < w; ++x) {
      pixels[y * stride + x] = static_cast<uint8_t>((pixels[y * stride + x] + pixels[y * stride + x - 1]) / 2);
    }
  }
  const ImageView image{pixels.data(), w, h, stride};
  static EpipolarCurve curve;
  static CurveSearchScratch scratch;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int32_t compared = 0, fallback = 0;
  for (int32_t trial = 0; trial < 60; ++trial) {
    NccTemplate t;
    CHECK(extractTemplate(image, 20 + grey(rng) % 260, 20 + grey(rng) % 180, t));
    // A straight or bent curve between two random points, some ends up to 30 px outside the image.
    const double x0 = -30.0 + unit(rng) * (w + 60), y0 = -30.0 + unit(rng) * (h + 60);
    const double x1 = -30.0 + unit(rng) * (w + 60), y1 = -30.0 + unit(rng) * (h + 60);
    const double bend = (unit(rng) - 0.5) * 40.0;
    const int32_t steps = 2 + static_cast<int32_t>(std::hypot(x1 - x0, y1 - y0));
    curve.count = 0;
    for (int32_t k = 0; k < steps && k < kMaxEpipolarSteps; ++k) {
      const double f = static_cast<double>(k) / (steps - 1);
      curve.x[curve.count] = static_cast<float>(x0 + f * (x1 - x0) + bend * f * (1.0 - f) * 4.0);
      curve.y[curve.count] = static_cast<float>(y0 + f * (y1 - y0));
      ++curve.count;
    }
    const int32_t band = trial % 5 == 4 ? kMaxEpipolarBandPx : trial % 5;
    const SearchHit b = searchAlongCurveDirect(t, image, curve, band);
    // The baseline kernels, then the AVX2 ones where the processor has them (VectorKernels.hpp).
    for (const bool avx2 : {false, true}) {
      allowMatchAvx2(avx2);
      const SearchHit a = searchAlongCurve(t, image, curve, band, scratch);
      CHECK_EQUAL(b.score, a.score);  // bit for bit
      CHECK_EQUAL(b.second, a.second);
      CHECK_EQUAL(b.x, a.x);
      CHECK_EQUAL(b.y, a.y);
    }
    compared += b.score > kNccInvalid ? 1 : 0;
  }
  // A long vertical curve with the widest band: more positions than the scratch holds (the fallback path).
  static uint8_t tall[1024 * 64];
  for (auto& p : tall) p = static_cast<uint8_t>(grey(rng));
  const ImageView tall_view{tall, 64, 1024, 64};
  curve.count = 0;
  for (int32_t k = 0; k < 1024; ++k) {
    curve.x[curve.count] = static_cast<float>(20.0 + 20.0 * std::sin(k * 0.01));
    curve.y[curve.count++] = static_cast<float>(k);
  }
  NccTemplate t;
  CHECK(extractTemplate(tall_view, 40, 150, t));  // on the curve: x = round(20 + 20 sin(1.5)) = 40
  const SearchHit a = searchAlongCurve(t, tall_view, curve, kMaxEpipolarBandPx, scratch);
  const SearchHit b = searchAlongCurveDirect(t, tall_view, curve, kMaxEpipolarBandPx);
  CHECK_EQUAL(b.score, a.score);
  CHECK_EQUAL(b.x, a.x);
  CHECK_EQUAL(b.y, a.y);
  fallback += (1024 - 10) * (2 * kMaxEpipolarBandPx + 1) > CurveSearchScratch::kMaxScores ? 1 : 0;
  std::printf("curve search: %d of 60 searches found a score, all equal to nccAt's (AVX2 kernels %s); fallback exercised: %d\n",
              compared, matchUsesAvx2() ? "compared too" : "not on this processor", fallback);
  CHECK(compared >= 40);
  CHECK_EQUAL(1, fallback);
  DOUBLES_EQUAL(1.0, a.score, 1e-12);  // the template's own window is on the curve
}
