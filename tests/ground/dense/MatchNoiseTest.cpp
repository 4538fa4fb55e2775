// The pair's matching-noise estimate (ground/dense/MatchNoise.hpp): on left-right differences with a known
// injected noise, and on the matcher's own output when the images' noise grows.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "ground/dense/DenseMatcher.hpp"
#include "ground/dense/MatchNoise.hpp"
#include "tests/ground/dense/TexturePair.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dense;

TEST_GROUP(MatchNoise){};

// Both directions carry independent noise of sd sigma (and a common offset the median removes, plus 2 %
// gross mismatches the MAD ignores); the estimate must find sigma within 4 standard errors of the MAD's
// sigma, 1.17 sigma / sqrt(n) for n independent samples.
TEST(MatchNoise, KnownInjectedNoiseWithinItsStandardError) {
  cv::RNG rng(7);
  for (const double sigma : {0.05, 0.15, 0.4}) {
    cv::Mat diff(300, 400, CV_32FC1, cv::Scalar(std::nanf("")));
    long long n = 0;
    for (int y = 0; y < diff.rows; ++y) {
      for (int x = 0; x < diff.cols; ++x) {
        if ((x + y) % 3 == 0) continue;  // no sample (NaN)
        const double left = rng.gaussian(sigma), right = rng.gaussian(sigma);
        const bool gross = rng.uniform(0.0, 1.0) < 0.02;
        diff.at<float>(y, x) =
            static_cast<float>(0.03 + left - right + (gross ? rng.uniform(-1.0, 1.0) : 0.0));
        ++n;
      }
    }
    const MatchNoise m = estimateMatchNoise(diff, 0.15);
    LONGS_EQUAL(n, m.samples);
    STRCMP_EQUAL("left_right", m.source.c_str());
    // 2 % contamination moves the MAD by ~2.5 % of sigma at most: part of the tolerance.
    DOUBLES_EQUAL(sigma, m.sigma_px, 4.0 * 1.17 * sigma / std::sqrt(static_cast<double>(n)) + 0.03 * sigma);
  }
}

TEST(MatchNoise, TooFewSamplesFallBackToTheConstantAndSaySo) {
  cv::Mat diff(10, 10, CV_32FC1, cv::Scalar(0.4f));
  const MatchNoise m = estimateMatchNoise(diff, 0.15);
  STRCMP_EQUAL("fallback_constant", m.source.c_str());
  DOUBLES_EQUAL(0.15, m.sigma_px, 0.0);
  LONGS_EQUAL(100, m.samples);
  const MatchNoise none = estimateMatchNoise(cv::Mat(), 0.2);
  STRCMP_EQUAL("fallback_constant", none.source.c_str());
  DOUBLES_EQUAL(0.2, none.sigma_px, 0.0);
  LONGS_EQUAL(0, none.samples);
}

// The matcher's left-right differences on a pair with a known disparity field: the estimate grows with the
// images' noise, and it stays of the order of the actual errors (within a factor of two of their sd).
TEST(MatchNoise, MatcherEstimateGrowsWithImageNoise) {
  auto disparity = [](double x, double y) {
    return 12.3 + 0.021 * x + 0.017 * y + 0.45 * std::sin(0.27 * x + 0.15 * y);
  };
  double previous = 0.0;
  for (const double noise_dn : {0.5, 4.0, 8.0}) {
    cv::RNG rng(11);
    cv::Mat l, r;
    areomap::test::texturedDisparityPair(rng, 400, 300, 40, 1.0, disparity, l, r);
    cv::Mat nl(l.size(), CV_32F), nr(r.size(), CV_32F);
    rng.fill(nl, cv::RNG::NORMAL, 0.0, noise_dn);
    rng.fill(nr, cv::RNG::NORMAL, 0.0, noise_dn);
    cv::Mat left, right;
    cv::Mat(l + nl).convertTo(left, CV_8U);
    cv::Mat(r + nr).convertTo(right, CV_8U);
    DenseOptions o;
    o.max_disparity_px = 40;
    const DenseResult d = matchRectified(left, right, o);
    const MatchNoise m = estimateMatchNoise(d.lr_diff_px, kMatchSigmaPx);
    STRCMP_EQUAL("left_right", m.source.c_str());
    double s2 = 0.0;
    long long n = 0;
    for (int y = 0; y < d.disparity.rows; ++y) {
      for (int x = 0; x < d.disparity.cols; ++x) {
        const float v = d.disparity.at<float>(y, x);
        if (!std::isfinite(v) || std::fabs(v - disparity(x, y)) > 1.0) continue;
        s2 += (v - disparity(x, y)) * (v - disparity(x, y));
        ++n;
      }
    }
    const double actual = std::sqrt(s2 / static_cast<double>(n));
    CHECK_TEXT(m.sigma_px > previous, "the estimate does not grow with the image noise");
    CHECK(m.sigma_px > 0.5 * actual && m.sigma_px < 2.0 * actual);
    previous = m.sigma_px;
  }
}

// The fill pass's block matches (DenseResult::block) carry their own estimate: on noisy low-contrast images
// with relief (the fill's use), the one-pixel class's left-right estimate and the block class's (its block
// disparities less the one-pixel ones, taken whole: PairCloud::block_noise) stay of the order of each class's
// actual errors (within a factor of two of their sd); the block matches' own left-right differences do not
// (they miss the relief the block smooths in both views).
TEST(MatchNoise, EachClassOfMatchesHasItsOwnEstimate) {
  auto disparity = [](double x, double y) {
    return 12.3 + 0.021 * x + 0.017 * y + 0.45 * std::sin(0.27 * x + 0.15 * y);
  };
  cv::RNG rng(23);
  cv::Mat l, r;
  areomap::test::texturedDisparityPair(rng, 600, 400, 40, 1.5, disparity, l, r);
  cv::Mat nl(l.size(), CV_32F), nr(r.size(), CV_32F);
  const double contrast = 0.3, noise_dn = 6.0;
  rng.fill(nl, cv::RNG::NORMAL, 0.0, noise_dn);
  rng.fill(nr, cv::RNG::NORMAL, 0.0, noise_dn);
  cv::Mat left, right;
  cv::Mat(contrast * l + nl + 80.0).convertTo(left, CV_8U);
  cv::Mat(contrast * r + nr + 80.0).convertTo(right, CV_8U);
  DenseOptions o;
  o.max_disparity_px = 40;
  const DenseResult d = matchRectified(left, right, o);
  double s2[2] = {0.0, 0.0};
  long long n[2] = {0, 0};
  for (int y = 0; y < d.disparity.rows; ++y) {
    for (int x = 0; x < d.disparity.cols; ++x) {
      const float v = d.disparity.at<float>(y, x);
      if (!std::isfinite(v) || std::fabs(v - disparity(x, y)) > 1.0) continue;
      const int k = d.block.at<uint8_t>(y, x) ? 1 : 0;
      s2[k] += (v - disparity(x, y)) * (v - disparity(x, y));
      ++n[k];
      CHECK(k == 1 || std::isnan(d.block_lr_diff_px.at<float>(y, x)));
      CHECK(k == 0 || std::isnan(d.lr_diff_px.at<float>(y, x)));
    }
  }
  const MatchNoise one = estimateMatchNoise(d.lr_diff_px, kMatchSigmaPx);
  MatchNoise block = estimateMatchNoise(d.block_check_px, 0.0);
  block.lr_sigma_px *= std::sqrt(2.0);
  const MatchNoise block_lr = estimateMatchNoise(d.block_lr_diff_px, 0.0);
  const double actual_one = std::sqrt(s2[0] / static_cast<double>(n[0]));
  const double actual_block = std::sqrt(s2[1] / static_cast<double>(std::max(1LL, n[1])));
  std::printf(
      "\none-pixel matches %lld: estimate %.3f px, actual %.3f px; block matches %lld (%lld checks): "
      "estimate %.3f px (their left-right differences: %.3f px), actual %.3f px\n",
      n[0], one.lr_sigma_px, actual_one, n[1], block.samples, block.lr_sigma_px, block_lr.lr_sigma_px,
      actual_block);
  CHECK(n[1] > 2000);  // the fill pass matched enough to measure its class
  CHECK(one.lr_sigma_px > 0.5 * actual_one && one.lr_sigma_px < 2.0 * actual_one);
  CHECK(block.lr_sigma_px > 0.5 * actual_block && block.lr_sigma_px < 2.0 * actual_block);
}
