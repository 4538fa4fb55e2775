// Least-squares sub-pixel refinement (ground/dense/SubpixelRefine.hpp) against the parabola through the
// aggregated costs, on rectified pairs rendered from one continuous texture with a KNOWN disparity field
// (TexturePair.hpp): a gently slanted plane, whose disparity's fractional part changes over ~50 px, and a
// ground plane at a grazing angle (0.13 px of disparity per row, the navcam head's base over its height).
// Three texture seeds each, image noise of 1 grey level. "Pixel locking" is the spread of the mean error
// over ten bins of the true disparity's fractional part: the parabola prefers whole pixels, so its error is
// a function of that fraction, and on smooth ground it is correlated as far as the fraction stays the same.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>

#include <opencv2/imgproc.hpp>

#include "ground/dense/DenseMatcher.hpp"
#include "ground/dense/SubpixelRefine.hpp"
#include "tests/ground/dense/TexturePair.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dense;

namespace {

constexpr int kWidth = 400, kHeight = 300, kPad = 40;

struct Score {
  long long matched = 0;
  double sd_px = 0.0;
  double locking_px = 0.0;  // max - min of the mean error over the fraction bins
  double mean_sigma_px = 0.0;
};

void renderPair(unsigned seed, const std::function<double(double, double)>& disparity, cv::Mat& left,
                cv::Mat& right) {
  cv::RNG rng(seed);
  cv::Mat l, r;
  areomap::test::texturedDisparityPair(rng, kWidth, kHeight, kPad, 1.0, disparity, l, r);
  cv::Mat noise(l.size(), CV_32FC1);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
  l += noise;
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
  r += noise;
  l.convertTo(left, CV_8UC1);
  r.convertTo(right, CV_8UC1);
}

Score score(const DenseResult& res, const std::function<double(double, double)>& disparity) {
  double sum[10] = {}, s = 0.0, s2 = 0.0, sig = 0.0;
  long long n[10] = {}, all = 0;
  for (int y = 8; y < kHeight - 8; ++y) {
    for (int x = 60; x < kWidth - 8; ++x) {
      const float d = res.disparity.at<float>(y, x);
      if (std::isnan(d)) continue;
      const double t = disparity(x, y), e = d - t;
      if (std::fabs(e) > 1.0) continue;
      const int bin = std::min(9, static_cast<int>((t - std::floor(t)) * 10.0));
      sum[bin] += e;
      ++n[bin];
      s += e;
      s2 += e * e;
      ++all;
      if (!res.sigma_px.empty()) sig += res.sigma_px.at<float>(y, x);
    }
  }
  Score out;
  out.matched = all;
  if (all == 0) return out;
  const double mean = s / static_cast<double>(all);
  out.sd_px = std::sqrt(std::max(0.0, s2 / static_cast<double>(all) - mean * mean));
  double lo = 1e9, hi = -1e9;
  for (int b = 0; b < 10; ++b) {
    if (n[b] == 0) continue;
    lo = std::min(lo, sum[b] / static_cast<double>(n[b]));
    hi = std::max(hi, sum[b] / static_cast<double>(n[b]));
  }
  out.locking_px = hi - lo;
  out.mean_sigma_px = sig / static_cast<double>(all);
  return out;
}

void compare(const char* name, const std::function<double(double, double)>& disparity, int max_disparity) {
  for (unsigned seed : {11u, 23u, 37u}) {
    cv::Mat left, right;
    renderPair(seed, disparity, left, right);
    DenseOptions o;
    o.max_disparity_px = max_disparity;
    const Score parabola = score(matchRectified(left, right, o), disparity);
    o.refine_subpixel = true;
    const DenseResult refined = matchRectified(left, right, o);
    const Score lsm = score(refined, disparity);
    std::printf(
        "\n  %s, texture %u: parabola sd %.3f px, locking %.3f px (%lld px) | least squares sd %.3f px, "
        "locking %.3f px (%lld px, %lld not refined), its own sigma %.3f px",
        name, seed, parabola.sd_px, parabola.locking_px, parabola.matched, lsm.sd_px, lsm.locking_px,
        lsm.matched, refined.subpixel.kept, lsm.mean_sigma_px);
    // The parabola's error is mostly locking on these pairs (the test would not show anything otherwise).
    CHECK(parabola.locking_px > 0.1);
    CHECK(lsm.locking_px < 0.4 * parabola.locking_px);
    CHECK(lsm.sd_px < 0.5 * parabola.sd_px);
    CHECK(lsm.matched >= 0.97 * static_cast<double>(parabola.matched));
    CHECK(lsm.mean_sigma_px > 0.0 && lsm.mean_sigma_px < lsm.sd_px * 4.0);
  }
  std::printf("\n");
}

}  // namespace

TEST_GROUP(SubpixelRefine){};

TEST(SubpixelRefine, RemovesPixelLockingOnAGentlePlane) {
  compare(
      "gentle plane", [](double x, double y) { return 12.3 + 0.021 * x + 0.017 * y; }, 40);
}

TEST(SubpixelRefine, RemovesPixelLockingOnGrazingGround) {
  compare(
      "grazing ground", [](double x, double y) { return 4.0 + 0.01 * x + 0.13 * y; }, 64);
}

// No texture along the row (the right image flat): the normal equations are singular; a window over the
// border: no fit. Both keep the matcher's disparity and no sigma; a textured window with the true shift
// is refined to it.
TEST(SubpixelRefine, KeepsTheMatchersValueWhereItCannotFit) {
  cv::Mat left(40, 60, CV_8UC1), right(40, 60, CV_8UC1, cv::Scalar(100));
  cv::RNG rng(5);
  rng.fill(left, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(left, left, cv::Size(0, 0), 1.0);
  left.colRange(33, 60).copyTo(right.colRange(30, 57));  // columns >= 33: disparity 3
  cv::Mat disparity(40, 60, CV_32FC1, cv::Scalar(2.8f)), valid(40, 60, CV_8UC1, cv::Scalar(0));
  valid.at<uint8_t>(20, 10) = 255;  // right window (columns 2..10, 3 px left of it) flat
  valid.at<uint8_t>(1, 45) = 255;   // window rows -2..4: over the border
  valid.at<uint8_t>(20, 45) = 255;  // textured: refined to 3
  cv::Mat sigma;
  const SubpixelStats s = refineSubpixel(left, right, disparity, valid, SubpixelOptions{}, &sigma);
  CHECK_EQUAL(2, s.kept);
  CHECK_EQUAL(1, s.refined);
  DOUBLES_EQUAL(2.8, disparity.at<float>(20, 10), 1e-6);
  DOUBLES_EQUAL(2.8, disparity.at<float>(1, 45), 1e-6);
  CHECK(std::isnan(sigma.at<float>(20, 10)));
  DOUBLES_EQUAL(3.0, disparity.at<float>(20, 45), 0.01);
  CHECK(sigma.at<float>(20, 45) >= 0.0f && sigma.at<float>(20, 45) < 0.05f);
}
