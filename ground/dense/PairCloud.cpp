#include "ground/dense/PairCloud.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "ground/dense/DenseMatcher.hpp"
#include "ground/dense/ParallaxCurve.hpp"
#include "ground/dense/Rectification.hpp"

namespace areomap::dense {

namespace {

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// The support range of a pair (horizontal focal length f px, baseline b m) for a DEM out to max_range_m.
double supportRangeM(const RectifiedPair& rect, double max_range_m) {
  const double fb = rect.left.h.cross(rect.left.a).norm() * rect.baseline_m;
  const double d_edge = fb / max_range_m;
  return d_edge > 2.0 * kSupportDisparityPx ? std::min(2.0 * max_range_m, fb / (d_edge - kSupportDisparityPx))
                                            : 2.0 * max_range_m;
}

// The pixel sigma of every kept match (PairCloud::block_noise): the pair's estimate for the one-pixel
// matches, the fill pass's own for its block matches, from the block disparities less the one-pixel ones at a
// sample of the one-pixel matches (DenseResult::block_check_px, BlockFill.hpp blockCheck): 1.4826 MAD of
// those differences, which hold the block class's errors whole (not the half of each of two views that
// estimateMatchNoise takes), and the one-pixel class's besides. Block matches without an estimate of their
// own (fewer than kMinMatchNoiseSamples differences, or a constant sigma asked for, which is calibrated for
// the one-pixel matches) are dropped from `d.disparity`: they would carry a sigma that is not theirs.
cv::Mat blockClassSigma(DenseResult& d, const PairCloudOptions& options, PairCloud& out) {
  cv::Mat sigma(d.disparity.size(), CV_32FC1, cv::Scalar(out.match_noise.sigma_px));
  if (d.block.empty()) return sigma;
  const cv::Mat block = d.block & (d.disparity == d.disparity);
  out.block_noise.samples = 0;
  if (cv::countNonZero(block) == 0) return sigma;
  if (options.estimate_match_sigma && !d.block_check_px.empty()) {
    out.block_noise = estimateMatchNoise(d.block_check_px, 0.0);
    out.block_noise.lr_sigma_px *= std::sqrt(2.0);
    if (out.block_noise.source == "left_right") {
      out.block_noise.sigma_px = out.block_noise.lr_sigma_px;
      out.block_noise.source = "block_check";
    }
  }
  if (out.block_noise.source == "block_check") {
    sigma.setTo(out.block_noise.sigma_px, block);
  } else {
    d.disparity.setTo(std::numeric_limits<float>::quiet_NaN(), block);
    out.block_noise.source = "dropped";
    out.block_noise.sigma_px = 0.0;
  }
  return sigma;
}

}  // namespace

cv::Mat insideOriginal(const cv::Mat& map) {
  cv::Mat m(map.rows, map.cols, CV_8U);
  for (int y = 0; y < map.rows; ++y) {
    const cv::Vec2f* row = map.ptr<cv::Vec2f>(y);
    for (int x = 0; x < map.cols; ++x) m.at<uint8_t>(y, x) = row[x][0] >= 0 ? 255 : 0;
  }
  cv::erode(m, m, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(kCensusWindowCols, kCensusWindowRows)));
  return m;
}

namespace {

// Only matches inside both original images count: the rectified images are black where no original pixel
// maps, and those borders (eroded by the matching window) must not make matches. Returns the valid count.
long long keepInside(const RectifiedPair& rect, cv::Mat& disparity) {
  const cv::Mat left_in = insideOriginal(rect.left_map), right_in = insideOriginal(rect.right_map);
  long long good = 0;
  for (int y = 0; y < disparity.rows; ++y) {
    float* row = disparity.ptr<float>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (!std::isfinite(row[x])) continue;
      const int xr = static_cast<int>(std::lround(x - row[x]));
      if (!left_in.at<uint8_t>(y, x) || xr < 0 || xr >= right_in.cols || !right_in.at<uint8_t>(y, xr)) {
        row[x] = NAN;
        continue;
      }
      ++good;
    }
  }
  return good;
}

}  // namespace

PairMatchSetup pairMatchSetup(const CameraModel& left, const CameraModel& right, const cv::Mat& left_grey,
                              const cv::Mat& right_grey, const std::vector<Vec2>& left_ties_px,
                              const std::vector<Vec2>& right_ties_px, const PairCloudOptions& options) {
  PairMatchSetup s;
  s.rect = rectifyPair(left, right);
  s.left = remapToRectified(left_grey, s.rect.left_map);
  s.right = remapToRectified(right_grey, s.rect.right_map);
  s.ties = rectifiedTies(left, right, s.rect, left_ties_px, right_ties_px);
  s.options.min_disparity_px = 0;
  s.options.max_disparity_px = std::max(
      options.max_disparity_px, static_cast<int>(std::ceil(disparityAtRange(s.rect, options.min_range_m))));
  s.match_mask = insideOriginal(s.rect.left_map);
  if (s.ties.size() >= 3)
    s.ranges = parallaxRowRanges(s.ties, s.left.rows, s.options.min_disparity_px, s.options.max_disparity_px);
  return s;
}

double keepMatchesInside(const RectifiedPair& rect, cv::Mat& disparity) {
  const long long good = keepInside(rect, disparity);
  const double shown = static_cast<double>(cv::countNonZero(insideOriginal(rect.left_map)));
  return static_cast<double>(good) / (shown + 1e-9);
}

PairCloud pairCloud(const CameraModel& left, const CameraModel& right, const cv::Mat& left_grey,
                    const cv::Mat& right_grey, const std::vector<Vec2>& left_ties_px,
                    const std::vector<Vec2>& right_ties_px, int pair_id, const PairCloudOptions& options) {
  return pairCloud(left, right, left_grey, right_grey, left_ties_px, right_ties_px, pair_id, options, nullptr);
}

PairCloud pairCloud(const CameraModel& left, const CameraModel& right, const cv::Mat& left_grey,
                    const cv::Mat& right_grey, const std::vector<Vec2>& left_ties_px,
                    const std::vector<Vec2>& right_ties_px, int pair_id, const PairCloudOptions& options,
                    const PointSink& sink) {
  PairCloud out;
  double t0 = now();
  PairMatchSetup s;
  try {
    s = pairMatchSetup(left, right, left_grey, right_grey, left_ties_px, right_ties_px, options);
  } catch (const std::exception& e) {
    out.error = std::string("cannot rectify (") + e.what() + ")";
    return out;
  }
  const RectifiedPair& rect = s.rect;
  const cv::Mat& l = s.left;
  out.ties = s.ties.size();
  out.seconds_rectify = now() - t0;
  t0 = now();
  DenseResult d;
  try {
    d = matchRectified(l, s.right, s.options, s.ranges.empty() ? nullptr : &s.ranges, s.match_mask);
  } catch (const std::exception& e) {
    out.error = std::string("dense matching failed (") + e.what() + ")";
    return out;
  }
  // Of the rectified pixels that show the left original (the rectified image may be larger than it).
  out.matched_fraction = keepMatchesInside(rect, d.disparity);
  // The noise estimates from the kept matches only (a NaN disparity is unequal to itself).
  const cv::Mat unkept = d.disparity != d.disparity;
  d.lr_diff_px.setTo(std::numeric_limits<float>::quiet_NaN(), unkept);
  if (!d.block_check_px.empty()) d.block_check_px.setTo(std::numeric_limits<float>::quiet_NaN(), unkept);
  out.seconds_dense = now() - t0;
  if (out.matched_fraction < options.min_matched_fraction) {
    out.error = "no valid dense matches (" + std::to_string(out.matched_fraction * 100) +
                " % of pixels; no texture?)";
    return out;
  }
  if (options.estimate_match_sigma) {
    out.match_noise = estimateMatchNoise(d.lr_diff_px, options.match_sigma_px);
  } else {
    out.match_noise.sigma_px = options.match_sigma_px;
    out.match_noise.source = "constant";
  }
  const cv::Mat sigma_px = blockClassSigma(d, options, out);
  t0 = now();
  out.support_range_m = supportRangeM(rect, options.max_range_m);
  if (sink) {
    const double support = out.support_range_m;
    triangulateDisparity(rect.left, rect.right, d.disparity, sigma_px, pair_id, l, out.stats,
                         kMaxDenseResidualPx, [&](const CloudPoint& p) { sink(p, support); });
  } else {
    std::vector<CloudPoint>& points = out.points;
    points.reserve(static_cast<std::size_t>(cv::countNonZero(d.disparity == d.disparity)));
    triangulateDisparity(rect.left, rect.right, d.disparity, sigma_px, pair_id, l, out.stats,
                         kMaxDenseResidualPx, [&points](const CloudPoint& p) { points.push_back(p); });
  }
  out.seconds_triangulate = now() - t0;
  return out;
}

}  // namespace areomap::dense
