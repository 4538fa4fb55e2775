// Epipolar rectification of a stereo pair from its (adjusted) camera models, for dense matching of pairs
// that are not delivered rectified (paper §4.1: the search follows the epipolar line of the adjusted
// models). After JPL's cmod_cahv_warp_models: both images are warped to linear CAHV models that share
// A, H and V (same orientation and image-plane vectors), with H' along the baseline, so that rows are
// epipolar lines; lens distortion (CAHVOR/CAHVORE) is removed exactly in the same resampling (the maps go
// from each rectified pixel through its ray to the distorted original pixel).
//
// Disparity in the rectified pair: left (x, y) matches right (x - d, y), d > 0 for points in front
// (the right camera lies along +H' of the left one). The rectified models describe the rectified images
// exactly, so triangulateDisparity(rectified.left, rectified.right, ...) intersects the matches.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dense/ParallaxCurve.hpp"

namespace areomap::dense {

struct RectifiedPair {
  CameraModel left;   // CAHV of the rectified left image
  CameraModel right;  // CAHV of the rectified right image (same A, H, V; C of the right camera)
  cv::Mat left_map;   // CV_32FC2: rectified left pixel -> original left pixel (x, y); (-1, -1) = none
  cv::Mat right_map;
  double baseline_m = 0.0;
  double max_rotation_rad = 0.0;  // the larger rotation of either camera into the common orientation
};

// Builds the common rectified CAHV pair and the resampling maps. The rectified images (both of one size,
// the models' width x height) cover every column either original shows and every row both show, at the
// originals' mean scale, or at a smaller one that keeps them within twice the left original's pixel
// count (the models' sizes must be set). Throws std::invalid_argument for a degenerate pair (zero
// baseline, baseline along the optical axis, missing size, no common row).
RectifiedPair rectifyPair(const CameraModel& left, const CameraModel& right);

// The disparity (rectified pixels) of a point at `range_m` straight ahead: hs b / range.
double disparityAtRange(const RectifiedPair& rectified, double range_m);

// Resamples an 8-bit image through a map of rectifyPair (bilinear; 0 outside the original).
cv::Mat remapToRectified(const cv::Mat& image, const cv::Mat& map);

// A pixel of the original (distorted) image in the rectified image, through its ray. False when the ray
// does not reach the rectified image plane.
bool originalToRectified(const CameraModel& original, const CameraModel& rectified, const Vec2& pixel,
                         Vec2& rectified_px);

// Tie disparities in the rectified pair from matched original pixels (left, right), for the parallax
// curve. Pairs that do not map are skipped.
std::vector<TieDisparity> rectifiedTies(const CameraModel& left, const CameraModel& right,
                                        const RectifiedPair& rectified, const std::vector<Vec2>& left_px,
                                        const std::vector<Vec2>& right_px);

}  // namespace areomap::dense
