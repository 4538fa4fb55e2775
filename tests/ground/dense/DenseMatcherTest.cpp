#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ground/dense/DenseMatcher.hpp"
#include "ground/dense/DisparityScore.hpp"
#include "ground/dense/ParallaxCurve.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dense;

namespace {

double nowS() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// OpenCV's StereoSGBM with the parameters its documentation recommends for a grey pair (block 5,
// P1 = 8 * 25, P2 = 32 * 25, uniqueness 10, speckle window 100 / range 2, LR check 1 px, 8 paths).
cv::Mat sgbmDisparity(const cv::Mat& left, const cv::Mat& right, int num_disp) {
  const int block = 5;
  cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(0, num_disp, block, 8 * block * block,
                                                        32 * block * block, 1, 63, 10, 100, 2,
                                                        cv::StereoSGBM::MODE_HH);
  cv::Mat d16;
  sgbm->compute(left, right, d16);
  cv::Mat out(d16.size(), CV_32FC1);
  for (int y = 0; y < d16.rows; ++y) {
    for (int x = 0; x < d16.cols; ++x) {
      const int16_t v = d16.at<int16_t>(y, x);
      out.at<float>(y, x) = v < 0 ? NAN : v / 16.0f;
    }
  }
  return out;
}

// A random-dot pair with a known disparity field: a slanted background and a raised square.
void syntheticPair(cv::Mat& left, cv::Mat& right, cv::Mat& truth) {
  const int w = 320, h = 240;
  cv::RNG rng(7);
  cv::Mat tex(h, w + 80, CV_8UC1);
  rng.fill(tex, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(tex, tex, cv::Size(3, 3), 0.8);
  left = cv::Mat(h, w, CV_8UC1);
  right = cv::Mat(h, w, CV_8UC1);
  truth = cv::Mat(h, w, CV_32FC1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const bool square = x > 120 && x < 220 && y > 70 && y < 170;
      truth.at<float>(y, x) = square ? 30.0f : 10.0f + 0.03f * y;
    }
  }
  // Right image: each right pixel shows the nearest surface point (z-buffer along the row).
  for (int y = 0; y < h; ++y) {
    std::vector<float> best(w, -1.0f);
    for (int x = 0; x < w; ++x) {
      const float d = truth.at<float>(y, x);
      const int xr = static_cast<int>(std::lround(x - d));
      if (xr >= 0 && xr < w && d > best[xr]) best[xr] = d;
    }
    for (int x = 0; x < w; ++x) left.at<uint8_t>(y, x) = tex.at<uint8_t>(y, x + 40);
    for (int xr = 0; xr < w; ++xr) {
      const int xl = static_cast<int>(std::lround(xr + std::max(best[xr], 10.0f)));
      right.at<uint8_t>(y, xr) = tex.at<uint8_t>(y, std::min(xl, w - 1) + 40);
    }
  }
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) truth.at<float>(y, x) = static_cast<float>(std::lround(truth.at<float>(y, x)));
  }
}

}  // namespace

TEST_GROUP(DenseMatcher){};

TEST(DenseMatcher, CensusOfAConstantImageIsZero) {
  const cv::Mat flat(20, 30, CV_8UC1, cv::Scalar(100));
  const cv::Mat c = censusTransform(flat);
  CHECK_EQUAL(0, cv::countNonZero(c.reshape(1)));
}

TEST(DenseMatcher, SyntheticRandomDotsRecoverTruth) {
  cv::Mat left, right, truth;
  syntheticPair(left, right, truth);
  DenseOptions o;
  o.max_disparity_px = 48;
  o.fill_holes = false;
  const DenseResult r = matchRectified(left, right, o);
  // Evaluate away from the square's occluded strip (to its left in the left image: x in 120-20..120).
  cv::Mat mask(truth.size(), CV_8UC1, cv::Scalar(255));
  mask(cv::Rect(95, 60, 40, 120)).setTo(0);
  mask(cv::Rect(0, 0, 50, truth.rows)).setTo(0);  // border: no right counterpart
  const DisparityScore s = scoreDisparity(r.disparity, truth, mask);
  std::printf("\nsynthetic 320x240: density %.2f %%, bad(>1px) %.3f %%\n", 100.0 * s.density(),
              100.0 * s.badRate());
  CHECK(s.density() > 0.97);
  CHECK(s.badRate() < 0.005);
}

TEST(DenseMatcher, RejectsBadInput) {
  const cv::Mat a(50, 60, CV_8UC1, cv::Scalar(1));
  const cv::Mat b(50, 61, CV_8UC1, cv::Scalar(1));
  DenseOptions o;
  CHECK_THROWS(std::invalid_argument, matchRectified(a, b, o));
  const cv::Mat c(50, 60, CV_8UC3, cv::Scalar(1, 1, 1));
  CHECK_THROWS(std::invalid_argument, matchRectified(c, c, o));
}

TEST(DenseMatcher, TexturelessPairGivesFewMatchesAndNoCrash) {
  const cv::Mat flat(80, 100, CV_8UC1, cv::Scalar(90));
  DenseOptions o;
  o.max_disparity_px = 20;
  o.fill_holes = false;
  const DenseResult r = matchRectified(flat, flat, o);
  // Every candidate has the same cost: the uniqueness test must refuse them.
  std::printf("\ntextureless: matched fraction %.3f\n", r.matched_fraction);
  CHECK(r.matched_fraction < 0.05);
}

// A "sky" over the synthetic pair: its top 80 rows are a flat grey with independent sensor noise in each
// image (sd 1.5 DN), which has texture but no correspondence. Semi-global aggregation carries the ground's
// disparities up into such a region and the left-right check passes them; the census-cost test
// (DenseOptions::max_census_cost_bits) must refuse them, and leave the ground as matched as before.
TEST(DenseMatcher, NoMatchesInANoiseOnlySky) {
  cv::Mat left, right, truth;
  syntheticPair(left, right, truth);
  const int sky_rows = 80;
  cv::RNG rng(11);
  for (cv::Mat* image : {&left, &right}) {
    cv::Mat noise(sky_rows, image->cols, CV_32FC1);
    rng.fill(noise, cv::RNG::NORMAL, 150.0, 1.5);
    noise.convertTo((*image)(cv::Rect(0, 0, image->cols, sky_rows)), CV_8UC1);
  }
  DenseOptions o;
  o.max_disparity_px = 48;
  // Row ranges as tie points give them (the ground's disparity +-4 px, carried up into the sky rows).
  std::vector<RowRange> ranges(static_cast<std::size_t>(left.rows));
  for (int y = 0; y < left.rows; ++y) {
    const int d = static_cast<int>(10.0 + 0.03 * std::max(y, sky_rows));
    ranges[static_cast<std::size_t>(y)] = RowRange{d - 4, d + 4};
  }
  // The census window's reach (4 rows) and the fill block's (DenseOptions::fill_block_px): the rows within it
  // of the ground see the ground's texture.
  const cv::Rect sky(50, 0, left.cols - 50, sky_rows - 4 - DenseOptions{}.fill_block_px / 2);
  const cv::Rect ground(230, sky_rows + 4, left.cols - 230, 40);  // right of the raised square
  const DenseResult with = matchRectified(left, right, o, &ranges);
  o.max_census_cost_bits = 62;  // the test off
  const DenseResult without = matchRectified(left, right, o, &ranges);
  const auto fraction = [](const DenseResult& r, const cv::Rect& box) {
    return static_cast<double>(cv::countNonZero(r.valid(box))) / box.area();
  };
  std::printf("\nnoise-only sky: matched %.1f %% with the census-cost test, %.1f %% without; ground below it %.1f / %.1f %%\n",
              100.0 * fraction(with, sky), 100.0 * fraction(without, sky), 100.0 * fraction(with, ground),
              100.0 * fraction(without, ground));
  CHECK(fraction(without, sky) > 0.08);  // the failure this guards against is there
  CHECK(fraction(with, sky) < 0.025);    // chance (2.8 % of windows) less the speckle filter
  CHECK(fraction(with, ground) > 0.97);
  CHECK(fraction(with, ground) > fraction(without, ground) - 0.01);
  // The fill pass (DenseOptions::fill_block_px, on in `with`) must not bring them back.
  o.max_census_cost_bits = DenseOptions{}.max_census_cost_bits;
  o.fill_block_px = 0;
  const DenseResult one = matchRectified(left, right, o, &ranges);
  std::printf("without the fill pass: sky %.1f %%, ground %.1f %%\n", 100.0 * fraction(one, sky),
              100.0 * fraction(one, ground));
  CHECK(fraction(with, ground) >= fraction(one, ground));
}

// Strong independent noise in both images (sd 8 DN): the one-pixel census cost is noisy and its tests refuse
// matches; the fill pass (fill_block_px) matches more of them and flags them as block matches with their own
// left-right differences (their errors are printed: the refused pixels include the occlusions beside the
// raised square, where no match is right).
TEST(DenseMatcher, FillPassMatchesWhatTheNoisyOnePixelCostRefuses) {
  cv::Mat left, right, truth;
  syntheticPair(left, right, truth);
  cv::RNG rng(5);
  for (cv::Mat* image : {&left, &right}) {
    cv::Mat noise(image->size(), CV_16SC1);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, 8.0);
    cv::Mat sum;
    cv::add(*image, noise, sum, cv::noArray(), CV_16SC1);
    sum.convertTo(*image, CV_8UC1);
  }
  DenseOptions o;
  o.max_disparity_px = 48;
  o.fill_block_px = 0;
  const DenseResult one = matchRectified(left, right, o);
  o.fill_block_px = DenseOptions{}.fill_block_px;
  const DenseResult both = matchRectified(left, right, o);
  const int blocks = cv::countNonZero(both.block);
  long long bad = 0, lr = 0, lr_on_one_px = 0;
  for (int y = 0; y < truth.rows; ++y)
    for (int x = 0; x < truth.cols; ++x) {
      if (!both.block.at<uint8_t>(y, x)) {
        if (std::isfinite(both.block_lr_diff_px.at<float>(y, x))) ++lr_on_one_px;
        continue;
      }
      if (std::fabs(both.disparity.at<float>(y, x) - truth.at<float>(y, x)) > 1.0f) ++bad;
      if (std::isfinite(both.block_lr_diff_px.at<float>(y, x))) ++lr;
    }
  std::printf("\nnoisy pair: density %.1f %% one-pixel, %.1f %% with the fill (%d block matches, %.1f %% > 1 px "
              "off)\n", 100.0 * one.matched_fraction, 100.0 * both.matched_fraction, blocks,
              100.0 * static_cast<double>(bad) / std::max(1, blocks));
  CHECK(both.matched_fraction > one.matched_fraction);
  CHECK(lr > blocks / 2);
  CHECK_EQUAL(0, lr_on_one_px);
  CHECK(cv::countNonZero(both.block & (both.valid == 0)) == 0);
}

TEST(DenseMatcher, ConesAgainstStereoSgbm) {
  if (!areomap::test::requireSharedData("middlebury-cones")) return;
  const std::string dir = areomap::test::sharedDataDir() + "/middlebury-cones/";
  const cv::Mat left = cv::imread(dir + "left.tif", cv::IMREAD_GRAYSCALE);
  const cv::Mat right = cv::imread(dir + "right.tif", cv::IMREAD_GRAYSCALE);
  const cv::Mat truth = cv::imread(dir + "disp_left.tif", cv::IMREAD_UNCHANGED);
  const cv::Mat occl = cv::imread(dir + "occl.png", cv::IMREAD_GRAYSCALE);
  CHECK_FALSE(left.empty() || right.empty() || truth.empty() || occl.empty());
  CHECK_EQUAL(CV_32FC1, truth.type());
  // occl.png: non-zero = non-occluded (visible in both images).
  cv::Mat nonocc = occl > 0;

  const double t0 = nowS();
  const cv::Mat sgbm = sgbmDisparity(left, right, 64);
  const double t1 = nowS();
  DenseOptions o;
  o.max_disparity_px = 63;
  const DenseResult ours = matchRectified(left, right, o);
  const double t2 = nowS();
  o.fill_holes = true;
  const DenseResult filled = matchRectified(left, right, o);
  const DisparityScore ss = scoreDisparity(sgbm, truth, nonocc);
  const DisparityScore so = scoreDisparity(ours.disparity, truth, nonocc);
  const DisparityScore sf = scoreDisparity(filled.disparity, truth, nonocc);
  std::printf("\nCones (non-occluded %lld px, bad = error > 1 px):\n", ss.evaluated);
  std::printf("  StereoSGBM        : bad %.2f %% at density %.2f %%, %.3f s\n", 100 * ss.badRate(),
              100 * ss.density(), t1 - t0);
  std::printf("  areomap (matched) : bad %.2f %% at density %.2f %%, %.3f s (coarse %.3f, fine %.3f, post %.3f)\n",
              100 * so.badRate(), 100 * so.density(), t2 - t1, ours.coarse_seconds, ours.fine_seconds,
              ours.post_seconds);
  std::printf("  areomap (+ filled): bad %.2f %% at density %.2f %% (holes filled from neighbours)\n",
              100 * sf.badRate(), 100 * sf.density());
  std::printf("  bad pixels: areomap %lld, SGBM %lld\n", so.bad, ss.bad);
  CHECK(so.bad <= ss.bad);
  CHECK(so.density() >= ss.density());
}

TEST_GROUP(ParallaxCurve){};

TEST(ParallaxCurve, FitsQuadraticAndRejectsOutlier) {
  std::vector<TieDisparity> ties;
  const int rows = 1000;
  for (int i = 0; i < 40; ++i) {
    const double y = 10.0 + 24.0 * i;
    const double t = y / rows;
    ties.push_back({100.0, y, 20.0 + 30.0 * t - 10.0 * t * t + ((i % 3) - 1) * 0.3});
  }
  ties.push_back({100.0, 500.0, 90.0});  // an outlier
  const ParallaxCurve c = fitParallaxCurve(ties, rows);
  DOUBLES_EQUAL(20.0, c.c0, 0.3);
  DOUBLES_EQUAL(30.0, c.c1, 1.5);
  DOUBLES_EQUAL(-10.0, c.c2, 1.5);
  CHECK_EQUAL(40, c.inliers);
  const std::vector<RowRange> r = parallaxRowRanges(ties, rows, 0, 128, 2, 32);
  CHECK_EQUAL(rows, static_cast<int>(r.size()));
  // Every tie lies inside its row's range; rows far from the outlier stay narrow.
  for (const TieDisparity& t : ties) {
    const RowRange& rr = r[static_cast<std::size_t>(t.y_px)];
    CHECK(t.disparity_px >= rr.lo && t.disparity_px <= rr.hi);
  }
  CHECK(r[100].hi - r[100].lo < 12);
  CHECK(r[500].hi >= 90);
}
