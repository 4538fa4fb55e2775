// Benchmark of the rover's tie-point matching on a 1024 x 1024 synthetic stereo pair, against OpenCV doing
// the comparable work in the same run: goodFeaturesToTrack (Harris-free Shi-Tomasi, as many corners as the
// Förstner detector keeps) + matchTemplate (TM_CCOEFF_NORMED, 11 x 11) over the bounding box of the same
// epipolar search band for every corner. Also prints the static memory of the rover workspaces.
// Run: build/tests/ground_ties_bench
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "firmware_core/adjust/NetworkBuilder.hpp"
#include "firmware_core/match/PanoramaMatcher.hpp"
#include "firmware_core/match/StereoMatcher.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/match/SyntheticStereo.hpp"

using namespace areomap;

namespace {

double seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

StereoWorkspace g_workspace;
StereoResult g_result;
PanoramaMatcher g_matcher;
CoarseDem g_dem;
EpipolarCurve g_curve;

}  // namespace

int main() {
  const int32_t size = 1024;
  const test::StereoScene a = test::makeStereoScene(size, 0.0, 0.7, 5);
  const test::StereoScene b = test::makeStereoScene(size, 0.6, 0.7, 5);
  StereoParams params;
  const int repeats = 3;

  // Rover: intra-stereo matching of one pair (Förstner, epipolar NCC, LR check, parallax curve, gridding).
  double rover_s = 1e9;
  for (int r = 0; r < repeats; ++r) {
    const double t0 = seconds();
    const Status s = matchStereoPair(a.leftView(), a.rightView(), a.left, a.right, params, g_workspace, g_result);
    rover_s = std::fmin(rover_s, seconds() - t0);
    if (!ok(s)) std::printf("rover: %s\n", statusName(s));
  }
  const StereoCounts& c = g_result.counts;

  // OpenCV: the same number of corners and the same search extent per corner (bounding box of the curve +-
  // band), one direction only (no left-right check, no parallax curve, no gridding).
  const cv::Mat left(size, size, CV_8UC1, const_cast<uint8_t*>(a.left_pixels.data()));
  const cv::Mat right(size, size, CV_8UC1, const_cast<uint8_t*>(a.right_pixels.data()));
  double cv_s = 1e9;
  int cv_corners = 0, cv_matched = 0;
  for (int r = 0; r < repeats; ++r) {
    const double t0 = seconds();
    std::vector<cv::Point2f> corners;
    cv::goodFeaturesToTrack(left, corners, c.interest_points, 0.01, 8.0);
    cv_corners = static_cast<int>(corners.size());
    cv_matched = 0;
    cv::Mat score;
    for (const cv::Point2f& p : corners) {
      const int x = static_cast<int>(std::lround(p.x)), y = static_cast<int>(std::lround(p.y));
      if (x < kNccRadius || y < kNccRadius || x >= size - kNccRadius || y >= size - kNccRadius) continue;
      if (!ok(epipolarCurve(a.left, a.right, Vec2(x, y), params.min_range_m, params.max_range_m, size, size,
                            g_curve))) {
        continue;
      }
      float x0 = 1e9f, x1 = -1e9f, y0 = 1e9f, y1 = -1e9f;
      for (int32_t k = 0; k < g_curve.count; ++k) {
        x0 = std::fmin(x0, g_curve.x[k]);
        x1 = std::fmax(x1, g_curve.x[k]);
        y0 = std::fmin(y0, g_curve.y[k]);
        y1 = std::fmax(y1, g_curve.y[k]);
      }
      const int band = params.band_px + kNccRadius;
      const cv::Rect box = cv::Rect(cv::Point(int(x0) - band, int(y0) - band), cv::Point(int(x1) + band + 2, int(y1) + band + 2)) &
                           cv::Rect(0, 0, size, size);
      if (box.width < kNccSide || box.height < kNccSide) continue;
      cv::matchTemplate(right(box), left(cv::Rect(x - kNccRadius, y - kNccRadius, kNccSide, kNccSide)), score,
                        cv::TM_CCOEFF_NORMED);
      double best = 0.0;
      cv::minMaxLoc(score, nullptr, &best);
      cv_matched += best >= params.min_ncc ? 1 : 0;
    }
    cv_s = std::fmin(cv_s, seconds() - t0);
  }

  // Whole pairs through the panorama matcher (intra + DEM + inter into the earlier pair), zero heap.
  g_matcher.reset();
  PairTieReport report;
  const ImageView al = a.leftView(), ar = a.rightView(), bl = b.leftView(), br = b.rightView();
  double t0 = seconds();
  (void)g_matcher.addPair(al, &ar, a.left, &a.right, g_dem, report);
  const double first_pair_s = seconds() - t0;
  HeapAllocationScope scope;
  t0 = seconds();
  (void)g_matcher.addPair(bl, &br, b.left, &b.right, g_dem, report);
  const double second_pair_s = seconds() - t0;
  const uint64_t heap = scope.allocations();

  std::printf("1024x1024 pair, best of %d runs\n", repeats);
  std::printf("rover intra-stereo: %.3f s (%d Förstner points, %d searched, %d NCC, %d left-right, %d parallax, "
              "%d selected)\n",
              rover_s, c.interest_points, c.searched, c.ncc_passed, c.lr_passed, c.parallax_passed, c.selected);
  std::printf("opencv goodFeaturesToTrack + matchTemplate: %.3f s (%d corners, %d with NCC >= %.2f; one direction, "
              "no checks)\n",
              cv_s, cv_corners, cv_matched, params.min_ncc);
  std::printf("ratio rover / opencv: %.2f\n", rover_s / cv_s);
  std::printf("panorama matcher: first pair %.3f s, second pair %.3f s (%d inter observations), heap allocations "
              "in the second pair: %llu\n",
              first_pair_s, second_pair_s, report.inter_observations, static_cast<unsigned long long>(heap));
  std::printf(
      "static memory: PanoramaMatcher %.2f MiB (StereoWorkspace %.2f MiB, ForstnerWorkspace %.2f MiB), "
      "CoarseDem %.2f MiB, NetworkBuilder %.2f MiB; budget %.0f MiB for the whole rover side\n",
      sizeof(PanoramaMatcher) / 1048576.0, sizeof(StereoWorkspace) / 1048576.0,
      sizeof(ForstnerWorkspace) / 1048576.0, sizeof(CoarseDem) / 1048576.0,
      sizeof(NetworkBuilder) / 1048576.0, kStaticMemoryBudgetBytes / 1048576.0);
  return 0;
}
