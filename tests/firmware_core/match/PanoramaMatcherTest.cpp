#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <vector>

#include "firmware_core/match/PanoramaMatcher.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/match/SyntheticStereo.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

PanoramaMatcher g_matcher;  // ~20 MiB, static as on the rover
CoarseDem g_dem;

}  // namespace

TEST_GROUP(PanoramaMatcher){};

// Three pairs from one mast, a-priori pointing off by ~10 px per pair: two azimuths of the lower tier and one upper-tier pair, 384 px, 45 degree field.
// Every observation of every point must lie within 1 px of the truth projection of the point's surface
// point (the ground plane under its first left observation); adjacent pairs share >= 10 inter-stereo ties.
TEST(PanoramaMatcher, IntraAndInterTiesAgreeWithTheTruthAndLinkAdjacentPairs) {
  const int32_t size = 384;
  const double poses[3][2] = {{0.0, 0.7}, {0.55, 0.7}, {0.25, 0.32}};
  std::vector<test::StereoScene> scenes;
  for (const auto& pose : poses) scenes.push_back(test::makeStereoScene(size, pose[0], pose[1], 21));
  // A-priori models off by a mast-head rotation per pair (up to ~13 px at f = 463 px), as the rover has them.
  const Vec3 errors[3] = {Vec3(0.012, -0.02, 0.008), Vec3(-0.01, 0.015, -0.02), Vec3(0.02, 0.01, 0.015)};
  const Vec3 mast(0.0, 0.0, -1.5);
  std::vector<CameraModel> apriori_left, apriori_right;
  for (size_t j = 0; j < scenes.size(); ++j) {
    const Mat3 r = rotationFromVector(errors[j]);
    apriori_left.push_back(movedModel(scenes[j].left, r, mast + r * (scenes[j].left.c - mast)));
    apriori_right.push_back(movedModel(scenes[j].right, r, mast + r * (scenes[j].right.c - mast)));
  }
  g_matcher.reset();
  g_matcher.stereo.grid_cell_px = 32;
  uint64_t allocations = 0;
  for (size_t j = 0; j < scenes.size(); ++j) {
    const ImageView l = scenes[j].leftView(), r = scenes[j].rightView();
    PairTieReport report;
    HeapAllocationScope scope;
    const Status s = g_matcher.addPair(l, &r, apriori_left[j], &apriori_right[j], g_dem, report);
    allocations += scope.allocations();
    std::printf("pair %zu: %s, intra %d selected (%s), dem %d points %d cells, inter: %d candidates, %d matched, "
                "%d rejected, %d observations, %d neighbours\n",
                j, statusName(s), report.intra.selected, statusName(report.intra_status), report.dem_points,
                report.dem_cells, report.inter_candidates, report.inter_matched, report.inter_rejected,
                report.inter_observations, report.neighbours);
    CHECK_EQUAL(static_cast<int>(Status::kOk), static_cast<int>(s));
  }
  CHECK_EQUAL(0u, allocations);
#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
  CHECK(heapCounterActive());  // the zero above is a count, not an absent counter (sanitizers own malloc)
#endif

  const auto& obs = g_matcher.observations();
  const auto& points = g_matcher.points();
  std::vector<Vec3> truth(points.size());
  std::vector<bool> has_truth(points.size(), false);
  for (int32_t i = 0; i < obs.size(); ++i) {
    const TieObservation& o = obs[i];
    if (o.kind == TieKind::kIntra && o.image % 2 == 0 && !has_truth[o.point]) {
      has_truth[o.point] = test::groundPoint(scenes[o.image / 2].left, Vec2(o.sample_px, o.line_px), truth[o.point]);
    }
  }
  int32_t within = 0, total = 0, inter_total = 0, inter_within = 0;
  std::map<std::pair<int, int>, std::set<int>> links;
  std::map<int, std::set<int>> pairs_of_point;
  for (int32_t i = 0; i < obs.size(); ++i) {
    const TieObservation& o = obs[i];
    CHECK(has_truth[o.point]);
    const test::StereoScene& sc = scenes[o.image / 2];
    Vec2 px;
    CHECK(project(o.image % 2 == 0 ? sc.left : sc.right, truth[o.point], px) == Status::kOk);
    const double e = (px - Vec2(o.sample_px, o.line_px)).norm();
    ++total;
    within += e <= 1.0 ? 1 : 0;
    if (o.kind == TieKind::kInter) {
      ++inter_total;
      inter_within += e <= 1.0 ? 1 : 0;
      if (e > 1.0) std::printf("  inter obs point %d image %d at (%.1f, %.1f): %.2f px, ncc %.3f\n", o.point, o.image, o.sample_px, o.line_px, e, o.score);
    }
    pairs_of_point[o.point].insert(o.image / 2);
  }
  for (const auto& [point, pairs] : pairs_of_point) {
    for (int a : pairs)
      for (int b : pairs)
        if (a < b) links[{a, b}].insert(point);
  }
  std::printf("panorama: %d points, %d observations (%d inter), within 1 px of truth: %.2f %% (inter %.2f %%); "
              "links 0-1 %zu, 0-2 %zu, 1-2 %zu\n",
              points.size(), total, inter_total, 100.0 * within / total, 100.0 * inter_within / std::max(1, inter_total),
              links[{0, 1}].size(), links[{0, 2}].size(), links[{1, 2}].size());
  CHECK(within >= 0.98 * total);
  CHECK(inter_within >= 0.98 * inter_total);
  const std::pair<int, int> same_tier(0, 1), across_a(0, 2), across_b(1, 2);
  CHECK(links[same_tier].size() >= 10);
  CHECK(links[across_a].size() >= 10);
  CHECK(links[across_b].size() >= 10);
  // One identity per surface point: no point has two observations in one image.
  std::set<std::pair<int, int>> seen;
  for (int32_t i = 0; i < obs.size(); ++i) CHECK(seen.insert({obs[i].point, obs[i].image}).second);
}
