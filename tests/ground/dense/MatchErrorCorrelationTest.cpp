// The source of dense::kMatchErrorCorrelationPx (DenseMatcher.hpp): how far the fine matcher's disparity
// errors stay correlated in the image. A synthetic pair with a KNOWN sub-pixel disparity field (a slanted
// plane, d = 12.3 + 0.021 x + 0.017 y, with relief of 1.1 px on it, so that the fractional part changes within
// a few pixels as on rough ground) is rendered from one continuous texture (a blurred random field, bicubic);
// the matcher's errors d - d_true on the valid pixels (bias removed, gross errors > 1 px left out) are
// autocorrelated along rows and along columns.
// The correlation length is the INTEGRAL scale, L = 1/2 + sum_{k>=1} r(k) (= L for r(k) = exp(-k / L);
// summed up to the first lag where r <= 0): what sets how the errors average down over a neighbourhood,
// which is how the DEM's sigma model (ground/dem/Kriging.hpp) uses it. The 1/e lag is printed too: the
// autocorrelation is not exponential (a sharp drop within the first pixels, then a negative lobe where the
// semi-global aggregation smooths the relief). On the plane alone the integral scale was 3.8 px (session 4's
// value of the constant): a long tail from the fractional part's slow change, which the relief removes.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "ground/dense/DenseMatcher.hpp"
#include "tests/ground/dense/TexturePair.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dense;

namespace {

constexpr double kA = 12.3, kB = 0.021, kC = 0.017;  // the plane: kA + kB x + kC y (left pixel)

// Relief on the plane: sum of sinusoids of 14-50 px wavelength and 1.1 px amplitude in all, so that the
// disparity's fractional part changes within a few pixels, as on rough ground. On the plane alone it changes
// over ~50 px and the sub-pixel error (which depends on it) repeats with it: a long correlated tail that
// relief does not have (r(3) = 0.44 along rows there; integral scale 3.8 px instead of the value below).
double trueDisparity(double x, double y) {
  constexpr double kTwoPi = 6.283185307179586;
  return kA + kB * x + kC * y + 0.45 * std::sin(kTwoPi * (x / 23.0 + y / 41.0) + 0.3) +
         0.35 * std::sin(kTwoPi * (x / 50.0 - y / 17.0) + 1.9) + 0.3 * std::sin(kTwoPi * (x / 14.0 + y / 29.0) + 4.1);
}

// Left(x, y) = T(x, y); right(xr, y) = T(x, y) where x - d(x, y) = xr (solved by fixed point: |dd/dx| < 0.2).
void slantedPair(cv::Mat& left, cv::Mat& right) {
  cv::RNG rng(11);
  cv::Mat l, r;
  areomap::test::texturedDisparityPair(rng, 400, 300, 40, 1.0, trueDisparity, l, r);
  l.convertTo(left, CV_8UC1);
  r.convertTo(right, CV_8UC1);
}

// Autocorrelation of the errors at lags 0..max_lag along x (dx = 1) or y (dy = 1); NaN = no error there.
std::vector<double> autocorrelation(const cv::Mat& err, int dx, int dy, int max_lag) {
  std::vector<double> r(static_cast<std::size_t>(max_lag) + 1, 0.0);
  for (int lag = 0; lag <= max_lag; ++lag) {
    double s = 0.0;
    long long n = 0;
    for (int y = 0; y + lag * dy < err.rows; ++y) {
      for (int x = 0; x + lag * dx < err.cols; ++x) {
        const float a = err.at<float>(y, x), b = err.at<float>(y + lag * dy, x + lag * dx);
        if (std::isnan(a) || std::isnan(b)) continue;
        s += static_cast<double>(a) * b;
        ++n;
      }
    }
    r[static_cast<std::size_t>(lag)] = n > 0 ? s / static_cast<double>(n) : 0.0;
  }
  const double r0 = r[0];
  for (double& v : r) v /= r0;
  return r;
}

// Integral scale: 1/2 + sum_{k>=1} r(k), up to the first lag where r is no longer positive.
double integralScale(const std::vector<double>& r) {
  double s = 0.5;
  for (std::size_t k = 1; k < r.size() && r[k] > 0.0; ++k) s += r[k];
  return s;
}

// The lag where r falls to 1/e, linear between lags (max_lag when it never does).
double eFoldingLag(const std::vector<double>& r) {
  const double target = std::exp(-1.0);
  for (std::size_t k = 1; k < r.size(); ++k) {
    if (r[k] <= target) return static_cast<double>(k - 1) + (r[k - 1] - target) / (r[k - 1] - r[k]);
  }
  return static_cast<double>(r.size() - 1);
}

}  // namespace

TEST_GROUP(MatchErrorCorrelation){};

TEST(MatchErrorCorrelation, MeasuredLengthIsTheNamedConstant) {
  cv::Mat left, right;
  slantedPair(left, right);
  DenseOptions o;
  o.max_disparity_px = 40;
  const DenseResult res = matchRectified(left, right, o);
  // Errors on valid pixels away from the borders (the right image has no counterpart left of x ~ 25).
  cv::Mat err(left.size(), CV_32FC1, cv::Scalar(NAN));
  double sum = 0.0, sum2 = 0.0;
  long long n = 0, gross = 0;
  for (int y = 8; y < left.rows - 8; ++y) {
    for (int x = 40; x < left.cols - 8; ++x) {
      const float d = res.disparity.at<float>(y, x);
      if (std::isnan(d)) continue;
      const double e = d - trueDisparity(x, y);
      if (std::fabs(e) > 1.0) {
        ++gross;
        continue;
      }
      err.at<float>(y, x) = static_cast<float>(e);
      sum += e;
      sum2 += e * e;
      ++n;
    }
  }
  CHECK(n > 50000);
  const double bias = sum / static_cast<double>(n);
  const double sd = std::sqrt(std::max(0.0, sum2 / static_cast<double>(n) - bias * bias));
  err -= bias;  // NaN stays NaN
  const int max_lag = 16;
  const std::vector<double> rx = autocorrelation(err, 1, 0, max_lag),
                            ry = autocorrelation(err, 0, 1, max_lag);
  const double ex = eFoldingLag(rx), ey = eFoldingLag(ry);
  const double lx = integralScale(rx), ly = integralScale(ry), l = 0.5 * (lx + ly);
  std::printf(
      "\n  match errors on %lld pixels (%lld gross > 1 px left out): bias %.3f px, sd %.3f px (kMatchSigmaPx "
      "%.2f)\n  autocorrelation along rows:   ",
      n, gross, bias, sd, kMatchSigmaPx);
  for (double v : rx) std::printf(" %.2f", v);
  std::printf("\n  autocorrelation along columns:");
  for (double v : ry) std::printf(" %.2f", v);
  std::printf(
      "\n  1/e lag: rows %.2f px, columns %.2f px; integral scale: rows %.2f px, columns %.2f px, mean %.2f "
      "px "
      "(kMatchErrorCorrelationPx %.2f)\n",
      ex, ey, lx, ly, l, kMatchErrorCorrelationPx);
  // The constant is this measurement (rounded); the errors are correlated over more than one pixel
  // (census window + SGM) and decorrelate within a few matching footprints.
  CHECK(std::fabs(l - kMatchErrorCorrelationPx) <= 0.15 * kMatchErrorCorrelationPx);
  CHECK(l > 1.0 && l < 10.0);
  CHECK(rx[static_cast<std::size_t>(max_lag)] < 0.2 && ry[static_cast<std::size_t>(max_lag)] < 0.2);
}
