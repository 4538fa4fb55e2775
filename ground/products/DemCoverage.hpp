// How much of what a stereo pair sees the DEM covers: of the DEM lattice's cells in a band of horizontal
// range from the left camera whose centre, placed on the ground, projects inside both images and is not
// hidden from either camera by the DEM's own terrain, the fraction that holds an elevation.
//
// The ground under a cell the DEM leaves empty is not known; it is taken from a plane fitted to points
// (GroundPlane) that the caller gives: the products fit it to the DEM's own cells near the rover
// (groundPlane), a check can fit it to independent points (fitGroundPlane). Such a cell counts as seen only
// when it is seen at every elevation the plane allows there (its prediction, +- three of its sigmas): where
// the plane is extrapolated (beyond its points) or the ground is rough, a cell at the edge of an image's
// view is not taken as seen on a guess. A cell is hidden when a filled DEM cell on the line from the camera
// rises above that line by more than twice its sigma (the DEM's own uncertainty, so that noise does not
// hide cells).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/DemRaster.hpp"

namespace areomap::products {

struct CoverageCount {
  long seen = 0;    // cells both cameras see
  long filled = 0;  // of those, cells with an elevation
  // filled / seen; -1 when no cell is seen.
  double fraction() const { return seen > 0 ? static_cast<double>(filled) / static_cast<double>(seen) : -1.0; }
  CoverageCount& operator+=(const CoverageCount& o) {
    seen += o.seen;
    filled += o.filled;
    return *this;
  }
};

// A least-squares plane of the ground, up = c(0) + c(1) (north - north0) + c(2) (east - east0), with the
// covariance of c and the scatter of the ground about it.
struct GroundPlane {
  double north0_m = 0.0, east0_m = 0.0;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  double sigma_m = 0.0;  // robust sd of the points about the plane
  double up(double north_m, double east_m) const;
  // Sd of the ground's elevation at (north, east) as the plane predicts it: the points' scatter and the
  // plane's own uncertainty there (which grows beyond the points).
  double sigmaUp(double north_m, double east_m) const;
};

// The plane through `points` (north, east, up), by least squares repeated with points beyond three robust
// sigmas (at least `min_bound_m`) left out, about their mean; false when fewer than three points.
bool fitGroundPlane(const std::vector<Vec3>& points, double min_bound_m, GroundPlane& plane);

// The elevation (up) of the DEM cell that holds (north, east); false for nodata or outside the grid.
bool demCellAt(const DemGrid& dem, double north_m, double east_m, double& elevation_m);

// Whether the DEM's terrain hides site point `x` (Z down) from a camera at `c`: sampled every `step_m`
// (horizontal; <= 0: half a cell) along the line, the last two samples before `x` left out. `sigma` may
// be null (no tolerance).
bool terrainHides(const DemGrid& dem, const DemGrid* sigma, const Vec3& c, const Vec3& x, double step_m = 0.0);

// fitGroundPlane through the DEM's filled cells within `radius_m` (horizontal) of `centre`, the bound at
// least a cell's size (a rough but level ground keeps its cells).
bool groundPlane(const DemGrid& dem, const Vec3& centre, double radius_m, GroundPlane& plane);

// The coverage of the band [lo_m, hi_m) of horizontal range from left.c (see above), counted on every
// k-th cell of the lattice in each direction, k = the whole cells in `sample_m` (at least 1), the lines of
// sight sampled at half that spacing: a figure of the band, not of each cell.
CoverageCount demCoverage(const DemGrid& dem, const DemGrid* sigma, const CameraModel& left,
                          const CameraModel& right, const GroundPlane& plane, double lo_m, double hi_m,
                          double sample_m = 0.0);

}  // namespace areomap::products
