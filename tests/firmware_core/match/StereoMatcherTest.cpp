#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "firmware_core/match/StereoMatcher.hpp"
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
