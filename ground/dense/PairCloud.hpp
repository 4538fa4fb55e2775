// One stereo pair to a point cloud (paper 4.1), the products' first stage: rectification with the
// adjusted models, parallax ranges from the pair's tie points, dense coarse-to-fine matching, matches kept
// only inside both original images, and space intersection through the models (per-point covariance from
// the pair's own sub-pixel matching noise, MatchNoise.hpp). Errors of one pair (it cannot be rectified, the
// matcher fails, too few valid matches: no texture) are returned as a message, never thrown: the other pairs
// go on.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dense/DenseMatcher.hpp"
#include "ground/dense/MatchNoise.hpp"
#include "ground/dense/Rectification.hpp"
#include "ground/dense/Triangulation.hpp"

namespace areomap::dense {

struct PairCloudOptions {
  // The disparity search reaches at least this, and at least the disparity of min_range_m in the rectified
  // pair (disparityAtRange): a larger or wider frame than the rover's needs more than a fixed bound.
  int max_disparity_px = 192;
  double min_range_m = 1.0;  // the nearest surface searched, as the tie matcher's (StereoParams::min_range_m)
  // The points' matching sigma is the pair's own estimate (MatchNoise.hpp) when estimate_match_sigma, else
  // (and where the estimate has too few samples) this one.
  bool estimate_match_sigma = true;
  double match_sigma_px = kMatchSigmaPx;
  double max_range_m = 60.0;           // the DEM's range: support_range_m is computed for it
  double min_matched_fraction = 0.02;  // fewer valid matches: the pair has no texture (an error)
};

struct PairCloud {
  std::string error;  // empty: matched; else why not (e.g. "cannot rectify (...)")
  std::vector<CloudPoint> points;
  std::size_t ties = 0;  // tie points that set the parallax ranges
  double matched_fraction =
      0.0;  // valid matches inside both images / rectified pixels showing the left image
  TriangulationStats stats;
  MatchNoise match_noise;  // the matching sigma the one-pixel matches' points carry, and where it came from
  // The same for the fill pass's block matches (DenseResult::block, BlockFill.hpp): source "block_check"
  // (from DenseResult::block_check_px), or "dropped" when they had too few samples to estimate it (their
  // points are then not made).
  MatchNoise block_noise;
  // Points are kept beyond max_range_m as support for the DEM, which stops at max_range_m: out to the
  // range whose disparity is kSupportDisparityPx below that of max_range_m (about 3 sd of the far matches'
  // disparity error, 0.33-0.36 px in tests/ground/products/far/FarRangeTest.cpp), at most twice
  // max_range_m. Cut at max_range_m itself, the outermost rows would keep only their points measured nearer
  // than they are (the range noise is metres at 60 m): a selection bias that lifted the DEM's outer metres
  // by decimetres.
  double support_range_m = 0.0;
  double seconds_rectify = 0.0, seconds_dense = 0.0, seconds_triangulate = 0.0;
};

inline constexpr double kSupportDisparityPx = 1.0;
inline constexpr double kMaxDenseResidualPx = 1.0;  // triangulateDisparity's default residual limit

// left/right: the adjusted models in the pixel frames of left_grey/right_grey (CV_8U); left_ties_px and
// right_ties_px: the measured pixels of the pair's tie points, one entry per point in both; pair_id names
// the points' rectified lines (LineId.hpp).
// What pairCloud hands the dense matcher: the rectified pair, the tie disparities, the matcher's options
// (disparity search from PairCloudOptions) and the per-row parallax ranges from the ties (empty with fewer
// than 3 ties: the whole range). Throws std::exception when the pair cannot be rectified.
struct PairMatchSetup {
  RectifiedPair rect;
  cv::Mat left, right;  // rectified grey
  std::vector<TieDisparity> ties;
  DenseOptions options;
  std::vector<RowRange> ranges;
  cv::Mat match_mask;  // the rectified left pixels that can give a kept match: insideOriginal(rect.left_map)
};
PairMatchSetup pairMatchSetup(const CameraModel& left, const CameraModel& right, const cv::Mat& left_grey,
                              const cv::Mat& right_grey, const std::vector<Vec2>& left_ties_px,
                              const std::vector<Vec2>& right_ties_px, const PairCloudOptions& options);

// The pixels of a rectified image (map: rectifyPair's left_map or right_map) that show the original, eroded
// by the census window (kCensusWindowCols x kCensusWindowRows): those whose window lies wholly on the
// original (255; else 0). No wider: near the top of a tilted image one row spans metres of the far ground,
// and each row the mask drops is ground the cameras see that the DEM gets no point in.
cv::Mat insideOriginal(const cv::Mat& map);

// Sets to NaN the matches that are not inside both original images (eroded by the matching window) and
// returns the valid matches left over the rectified pixels that show the left original (the same erosion):
// PairCloud::matched_fraction.
double keepMatchesInside(const RectifiedPair& rect, cv::Mat& disparity);

PairCloud pairCloud(const CameraModel& left, const CameraModel& right, const cv::Mat& left_grey,
                    const cv::Mat& right_grey, const std::vector<Vec2>& left_ties_px,
                    const std::vector<Vec2>& right_ties_px, int pair_id, const PairCloudOptions& options);
// pairCloud with each point handed to sink(point, support_range_m) in the same order instead of kept in
// `points` (which stays empty): for a caller that keeps a part of the points or a smaller record of each.
using PointSink = std::function<void(const CloudPoint&, double support_range_m)>;
PairCloud pairCloud(const CameraModel& left, const CameraModel& right, const cv::Mat& left_grey,
                    const cv::Mat& right_grey, const std::vector<Vec2>& left_ties_px,
                    const std::vector<Vec2>& right_ties_px, int pair_id, const PairCloudOptions& options,
                    const PointSink& sink);

}  // namespace areomap::dense
