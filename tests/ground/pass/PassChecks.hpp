// Independent checks of a ground pass where no truth exists (real pairs), shared by the pass tests:
//   - feature matches found without areomap's matcher (OpenCV SIFT, Lowe's ratio test, mutual best) on the
//     original images, triangulated through a pair of models and reprojected: the RMS reprojection
//     residual says how well those models' relative orientation explains matches the adjustment never saw;
//   - the DEM's coverage of the cells that both cameras see in a band of horizontal range.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/DemRaster.hpp"

namespace areomap::test {

struct FeatureMatches {
  std::vector<Vec2> left_px, right_px;
};

// SIFT features of both images, each left feature's two nearest right descriptors with the ratio test
// (best < 0.75 second), kept when the right feature's best left match is the same feature.
FeatureMatches siftMatches(const cv::Mat& left, const cv::Mat& right);

// The RMS (over both images) reprojection distance of the match triangulated through the two models
// (Gauss-Newton from the rays' midpoint); negative when it does not triangulate in front of both.
double reprojectionResidualPx(const CameraModel& left, const CameraModel& right, const Vec2& left_px,
                              const Vec2& right_px);

struct ModelComparison {
  int matches = 0;  // used: within `gross_px` under at least one of the two model pairs
  double rms_a_px = 0.0;
  double rms_b_px = 0.0;
};

// Both model pairs on the same matches; a match beyond `gross_px` under both is a wrong match and left out
// (the rule treats a and b alike).
ModelComparison compareModels(const FeatureMatches& m, const CameraModel& a_left, const CameraModel& a_right,
                              const CameraModel& b_left, const CameraModel& b_right, double gross_px = 2.0);

// ground/products demCoverage of the band [lo_m, hi_m) with the plane of the DEM's cells within 2 hi_m of
// the camera and no sigma tolerance on hidden cells; -1 when no cell is seen.
double demCoverage(const DemGrid& dem, const CameraModel& left, const CameraModel& right, double lo_m,
                   double hi_m);

// The sol-1280 Navcam pair of ../shared/data/m2020-navcam-stereo-pairs (rover navigation frame, 1280 x 960
// delivered at scale 4: fisheye-linearity CAHVORE with its real R and E), copied here so that the tests that
// use it need no shared data.
CameraModel navcam(bool right);
// The detector (5120 x 3840): a delivered pixel p of the scale-4 frame is detector pixel 4 p + 1.5.
CameraModel detector(bool right);
// A half-resolution quarter-sensor tile (1288 x 968) whose first detector pixel is (x0, y0) (0-based).
CameraModel tile(bool right, double x0, double y0);

// A synthetic image of the textured plane Z = plane_z_m (site frame, Z down) through `model`
// (model.width x model.height, 8-bit): value noise of four octaves (1 cm to 30 cm) from `seed`, the same
// surface for every camera; rays that miss the plane (above the horizon) see a flat sky. Each pixel's
// ground point is exact on a grid of every 4th pixel and bilinear between (smooth at that scale), so that
// a 5120 x 3840 frame renders in seconds.
cv::Mat renderPlane(const CameraModel& model, double plane_z_m, unsigned seed);

// The point of the plane Z = plane_z_m on the ray of `pixel`; false when the ray misses it.
bool planePoint(const CameraModel& model, const Vec2& pixel, double plane_z_m, Vec3& point);

struct RectificationCover {
  int width = 0, height = 0;  // of the rectified pair
  int overlap = 0;      // original left pixels (every 4th) whose ray at `range_m` falls in the right image
  double inside = 0.0;  // the fraction of those inside the rectified left image
};

// ground/dense rectifyPair on the two models, and how much of their overlap the rectified left image keeps.
RectificationCover rectificationCover(const CameraModel& left, const CameraModel& right, double range_m);

}  // namespace areomap::test
