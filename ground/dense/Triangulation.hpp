// Space intersection of matched pixels with the adjusted camera models (paper §4.1), with its precision,
// and the point cloud of a pair in the site frame (+X north, +Y east, +Z down, metres).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "firmware_core/camera/RayIntersection.hpp"

namespace areomap::dense {

struct CloudPoint {
  Vec3 site_m = Vec3::Zero();
  Mat3 covariance_m2 = Mat3::Zero();  // from the pixel sigma through the intersection
  double residual_px = 0.0;            // RMS reprojection residual of the intersection
  uint8_t grey = 0;
  int64_t line = -1;                   // equi-parallax line: lineId(pair id, left row) (LineId.hpp)
  double sigmaHeight_m() const { return std::sqrt(std::max(0.0, covariance_m2(2, 2))); }
};

// Least-squares intersection of the rays of pixel `left_px` in `left` and `right_px` in `right`
// (intersectPixels, firmware_core/camera/RayIntersection.hpp), covariance sigma_px^2 (J^T J)^-1. False when
// a ray does not exist, the rays are parallel, the point is behind a camera, or the solution does not
// converge.
bool triangulate(const CameraModel& left, const CameraModel& right, const Vec2& left_px, const Vec2& right_px,
                 double sigma_px, CloudPoint& out);

// Most rays intersectRays takes (the rover's capacity of observations per point).
using areomap::kMaxIntersectionViews;

// intersectPixels over 2..kMaxIntersectionViews rays (the observations of one tie point in several images).
// `residuals_px[i]` = |pixels[i] - projection of `point`|, the back-projection residual of observation i
// with these models. False when a ray does not exist, the first two are parallel, or a projection fails.
bool intersectRays(const std::vector<const CameraModel*>& models, const std::vector<Vec2>& pixels, Vec3& point,
                   std::vector<double>& residuals_px);

struct TriangulationStats {
  long long matches = 0;
  long long triangulated = 0;
  long long rejected_geometry = 0;   // no ray, parallel, behind, no convergence
  long long rejected_residual = 0;   // reprojection residual above the limit
};

// Every finite disparity of a pair whose left/right images are those of `left` and `right` (a rectified
// pair, or any pair with row-aligned epipolar lines): left (x, y) matches right (x - d, y). Points with an
// RMS residual above `max_residual_px` are dropped. `grey` (optional, CV_8U) gives each point its value.
std::vector<CloudPoint> triangulateDisparity(const CameraModel& left, const CameraModel& right,
                                             const cv::Mat& disparity, double sigma_px, int64_t pair_id,
                                             const cv::Mat& grey, TriangulationStats& stats,
                                             double max_residual_px = 1.0);
// triangulateDisparity with each point handed to `sink` in the same order instead of kept: for a caller that
// keeps a part of the points or a smaller record of each (a pair's cloud is ~1e6 points of 120 B).
void triangulateDisparity(const CameraModel& left, const CameraModel& right, const cv::Mat& disparity,
                          double sigma_px, int64_t pair_id, const cv::Mat& grey, TriangulationStats& stats,
                          double max_residual_px, const std::function<void(const CloudPoint&)>& sink);
// The same with each match's own pixel sigma (`sigma_px`, CV_32F of the disparity's size): the matcher's
// classes of matches (DenseResult::block) carry noise estimates of their own (PairCloud::block_noise).
void triangulateDisparity(const CameraModel& left, const CameraModel& right, const cv::Mat& disparity,
                          const cv::Mat& sigma_px, int64_t pair_id, const cv::Mat& grey,
                          TriangulationStats& stats, double max_residual_px,
                          const std::function<void(const CloudPoint&)>& sink);

// Binary little-endian PLY: double x y z (site frame), float sigma_x sigma_y sigma_z (m), uchar grey,
// int line. Throws std::runtime_error naming the file when it cannot be written (checked after close).
// Written in place: products write it through cli::writeViaTemporary.
void writePly(const std::string& path, const std::vector<CloudPoint>& points, const std::string& comment = "");
// The same, streamed: `count` points, the i-th made by `point(i)` as it is written (no copy of a cloud kept
// in another layout).
void writePly(const std::string& path, std::size_t count, const std::function<CloudPoint(std::size_t)>& point,
              const std::string& comment = "");

// Reads a PLY written by writePly (site_m, the per-axis sigmas as a diagonal covariance, grey, line).
// Throws std::runtime_error naming the file when it is missing, not in that layout, or truncated.
std::vector<CloudPoint> readPly(const std::string& path);

}  // namespace areomap::dense
