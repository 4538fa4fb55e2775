#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "firmware_core/match/ForstnerDetector.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/match/SyntheticStereo.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

ForstnerWorkspace g_workspace;  // 8 MiB: static, as on the rover
InterestPoint g_points[kMaxInterestPoints];

// w and q written out from the definition: gx = (I(x+1,y) - I(x-1,y)) / 2, gy likewise, N summed over the
// (2r+1)^2 window, w = det/tr, q = 4 det/tr^2 -- all in double, no running sums.
void referenceWq(const std::vector<uint8_t>& img, int32_t w, int32_t x, int32_t y, int32_t r, double& wv, double& qv) {
  double nxx = 0, nxy = 0, nyy = 0;
  for (int32_t v = y - r; v <= y + r; ++v) {
    for (int32_t u = x - r; u <= x + r; ++u) {
      const double gx = 0.5 * (double(img[v * w + u + 1]) - double(img[v * w + u - 1]));
      const double gy = 0.5 * (double(img[(v + 1) * w + u]) - double(img[(v - 1) * w + u]));
      nxx += gx * gx;
      nxy += gx * gy;
      nyy += gy * gy;
    }
  }
  const double tr = nxx + nyy, det = nxx * nyy - nxy * nxy;
  wv = tr > 0 ? det / tr : 0.0;
  qv = tr > 0 ? 4.0 * det / (tr * tr) : 0.0;
}

}  // namespace

TEST_GROUP(ForstnerDetector){};

TEST(ForstnerDetector, WeightAndRoundnessAgreeWithDirectComputation) {
  const int32_t w = 48, h = 40;
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> dist(0, 255);
  std::vector<uint8_t> img(w * h);
  for (auto& p : img) p = static_cast<uint8_t>(dist(rng));
  const ImageView view{img.data(), w, h, w};
  for (int32_t r = 1; r <= 3; ++r) {
    ForstnerParams params;
    params.window_radius = r;
    CHECK_EQUAL(static_cast<int>(Status::kOk), static_cast<int>(computeForstnerMaps(view, params, g_workspace)));
    double max_rel_w = 0.0, max_abs_q = 0.0;
    int32_t compared = 0;
    for (int32_t y = r + 1; y <= h - r - 2; ++y) {
      for (int32_t x = r + 1; x <= w - r - 2; ++x) {
        double wv, qv;
        referenceWq(img, w, x, y, r, wv, qv);
        max_rel_w = std::fmax(max_rel_w, std::fabs(g_workspace.weight[y * w + x] - wv) / std::fmax(1.0, wv));
        max_abs_q = std::fmax(max_abs_q, std::fabs(g_workspace.roundness[y * w + x] - qv));
        ++compared;
      }
    }
    std::printf("forstner r=%d: %d pixels, max relative w error %.2e, max q error %.2e\n", r, compared, max_rel_w,
                max_abs_q);
    CHECK(max_rel_w < 1e-6);  // float storage of an exact integer sum
    CHECK(max_abs_q < 1e-6);
    // Undefined border: zero.
    DOUBLES_EQUAL(0.0, g_workspace.weight[r * w + w / 2], 0.0);
  }
}

TEST(ForstnerDetector, FindsCornersOfSquaresAtSubPixelAccuracy) {
  // Dark squares of 8 px on a bright field, corners at known pixel-edge positions (x.5 between pixels).
  const int32_t w = 96, h = 96;
  std::vector<uint8_t> img(w * h, 200);
  std::vector<Vec2> corners;
  for (int32_t by = 16; by < 80; by += 24) {
    for (int32_t bx = 16; bx < 80; bx += 24) {
      for (int32_t y = by; y < by + 8; ++y)
        for (int32_t x = bx; x < bx + 8; ++x) img[y * w + x] = 40;
      corners.emplace_back(bx - 0.5, by - 0.5);
      corners.emplace_back(bx + 7.5, by - 0.5);
      corners.emplace_back(bx - 0.5, by + 7.5);
      corners.emplace_back(bx + 7.5, by + 7.5);
    }
  }
  ForstnerParams params;
  params.cell_px = 16;
  params.max_per_cell = 4;
  params.min_points = 4;
  params.nms_radius = 2;
  int32_t count = 0;
  const Status s = detectInterestPoints(ImageView{img.data(), w, h, w}, params, g_workspace, g_points,
                                        kMaxInterestPoints, count);
  CHECK_EQUAL(static_cast<int>(Status::kOk), static_cast<int>(s));
  // Every corner is found within 1 px, and nothing is found far from a corner.
  int32_t found = 0;
  double worst = 0.0;
  for (const Vec2& c : corners) {
    double best = 1e9;
    for (int32_t i = 0; i < count; ++i) best = std::fmin(best, (Vec2(g_points[i].x_px, g_points[i].y_px) - c).norm());
    worst = std::fmax(worst, best);
    found += best <= 1.0 ? 1 : 0;
  }
  for (int32_t i = 0; i < count; ++i) {
    double best = 1e9;
    for (const Vec2& c : corners) best = std::fmin(best, (Vec2(g_points[i].x_px, g_points[i].y_px) - c).norm());
    CHECK(best < 2.0);
  }
  std::printf("forstner corners: %d of %zu found (worst %.2f px), %d points\n", found, corners.size(), worst, count);
  CHECK_EQUAL(static_cast<int32_t>(corners.size()), found);
}

TEST(ForstnerDetector, SpreadsPointsOverTheImageWithoutHeap) {
  const test::StereoScene scene = test::makeStereoScene(256);
  ForstnerParams params;
  int32_t count = 0;
  HeapAllocationScope scope;
  const Status s = detectInterestPoints(scene.leftView(), params, g_workspace, g_points, kMaxInterestPoints, count);
  CHECK_EQUAL(0u, scope.allocations());
  CHECK_EQUAL(static_cast<int>(Status::kOk), static_cast<int>(s));
  // Every 32-px cell holds at most 2 points, and at least 80 % of the 64 cells have one.
  int32_t per_cell[64] = {};
  for (int32_t i = 0; i < count; ++i) {
    const int32_t c = g_points[i].pixel_y / 32 * 8 + g_points[i].pixel_x / 32;
    ++per_cell[c];
    CHECK(g_points[i].roundness > params.q_min);
  }
  int32_t occupied = 0;
  for (int32_t c = 0; c < 64; ++c) {
    CHECK(per_cell[c] <= 2);
    occupied += per_cell[c] > 0 ? 1 : 0;
  }
  std::printf("forstner spread: %d points, %d of 64 cells occupied\n", count, occupied);
  CHECK(occupied >= 52);
}

TEST(ForstnerDetector, BlankAndSaturatedImagesHaveNoTexture) {
  std::vector<uint8_t> img(128 * 128, 0);
  ForstnerParams params;
  int32_t count = -1;
  for (uint8_t value : {uint8_t(0), uint8_t(128), uint8_t(255)}) {
    std::fill(img.begin(), img.end(), value);
    const Status s = detectInterestPoints(ImageView{img.data(), 128, 128, 128}, params, g_workspace, g_points,
                                          kMaxInterestPoints, count);
    CHECK_EQUAL(static_cast<int>(Status::kNoTexture), static_cast<int>(s));
    CHECK_EQUAL(0, count);
  }
  // A faint ramp (1 grey level per 8 px) is still below the texture floor.
  for (int32_t y = 0; y < 128; ++y)
    for (int32_t x = 0; x < 128; ++x) img[y * 128 + x] = static_cast<uint8_t>(100 + (x + y) / 8);
  const Status s = detectInterestPoints(ImageView{img.data(), 128, 128, 128}, params, g_workspace, g_points,
                                        kMaxInterestPoints, count);
  CHECK_EQUAL(static_cast<int>(Status::kNoTexture), static_cast<int>(s));
}

TEST(ForstnerDetector, RejectsBadArguments) {
  uint8_t px[16] = {};
  ForstnerParams params;
  int32_t count = 0;
  CHECK_EQUAL(static_cast<int>(Status::kInvalidArgument),
              static_cast<int>(detectInterestPoints(ImageView{}, params, g_workspace, g_points, 10, count)));
  params.window_radius = kMaxForstnerRadius + 1;
  CHECK_EQUAL(static_cast<int>(Status::kInvalidArgument),
              static_cast<int>(computeForstnerMaps(ImageView{px, 4, 4, 4}, params, g_workspace)));
  params.window_radius = 2;
  CHECK_EQUAL(static_cast<int>(Status::kCapacityExceeded),
              static_cast<int>(computeForstnerMaps(ImageView{px, kMaxImageWidth + 1, 1, kMaxImageWidth + 1}, params,
                                                   g_workspace)));
}
