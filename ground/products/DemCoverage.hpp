// How much of what a stereo pair sees the DEM covers: of the DEM lattice's cells in a band of horizontal
// range from the left camera whose centre, placed on the ground, projects inside both images and is not
// hidden from either camera by the DEM's own terrain, the fraction that holds an elevation.
//
// The ground under a cell the DEM leaves empty is not known; it is taken from a plane (z up = a + b north
// + c east) that the caller gives: the products fit it to the DEM's own cells near the rover
// (groundPlane), a check can fit it to independent points. A cell is hidden when a filled DEM cell on the
// line from the camera rises above that line by more than twice its sigma (the DEM's own uncertainty, so
// that noise does not hide cells).
#pragma once

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

// z up = plane(0) + plane(1) north + plane(2) east.
using GroundPlane = Eigen::Vector3d;

// The elevation (up) of the DEM cell that holds (north, east); false for nodata or outside the grid.
bool demCellAt(const DemGrid& dem, double north_m, double east_m, double& elevation_m);

// Whether the DEM's terrain hides site point `x` (Z down) from a camera at `c`: sampled every `step_m`
// (horizontal; <= 0: half a cell) along the line, the last two samples before `x` left out. `sigma` may
// be null (no tolerance).
bool terrainHides(const DemGrid& dem, const DemGrid* sigma, const Vec3& c, const Vec3& x, double step_m = 0.0);

// The plane through the DEM's filled cells within `radius_m` (horizontal) of `centre`, by least squares
// repeated with cells beyond three robust sigmas left out; false when fewer than three cells.
bool groundPlane(const DemGrid& dem, const Vec3& centre, double radius_m, GroundPlane& plane);

// The coverage of the band [lo_m, hi_m) of horizontal range from left.c (see above), counted on every
// k-th cell of the lattice in each direction, k = the whole cells in `sample_m` (at least 1), the lines of
// sight sampled at half that spacing: a figure of the band, not of each cell.
CoverageCount demCoverage(const DemGrid& dem, const DemGrid* sigma, const CameraModel& left,
                          const CameraModel& right, const GroundPlane& plane, double lo_m, double hi_m,
                          double sample_m = 0.0);

}  // namespace areomap::products
