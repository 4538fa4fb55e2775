// Ordinary kriging of a point cloud onto a DEM grid (paper §4.1): the fitted variogram (Variogram.hpp),
// the k nearest points of each cell from a k-d tree, one (k+1)x(k+1) solve per cell, and the kriging
// standard deviation as a second raster (dem_sigma.tif).
//
// The kriging is "filtered": the nugget and each point's own sigma are treated as measurement noise, so
// the estimate and its sigma are those of the noise-free surface. The sigma is calibrated by leave-one-out
// cross-validation on a sample of points (sigma_scale), so that it stays honest when the variogram model
// only approximates the surface. Grids are ground/dataset's DemGrid
// (north-up, columns east = site +Y, rows south = site -X, elevation up = -Z).
#pragma once

#include <cstdint>
#include <vector>

#include "ground/dataset/DemRaster.hpp"
#include "ground/dem/Variogram.hpp"

namespace areomap::dem {

struct DemPoint {
  double north_m = 0.0;      // site +X
  double east_m = 0.0;       // site +Y
  double elevation_m = 0.0;  // site -Z
  double sigma_m = 0.0;      // height standard deviation of the point (0 = unknown)
  int64_t line = -1;         // equi-parallax line id (pair and rectified row), -1 = unknown
};

struct KrigingOptions {
  int neighbours = 16;           // k (at most kMaxNeighbours)
  double max_gap_m = -1.0;       // cells farther than this from every point stay nodata (-1: automatic)
  double max_lag_m = -1.0;       // variogram extent (-1: 6 neighbourhood radii, at most 1/3 of the cloud)
  bool use_point_sigma = true;   // point sigmas enter the diagonal (at least the nugget)
  const VariogramModel* model = nullptr;  // given model instead of the fitted one
  int threads = 0;  // threads for the cells (0: one per core); the result is the same for any number
};

inline constexpr int kMaxKrigingThreads = 64;

inline constexpr int kMaxNeighbours = 64;

struct KrigingResult {
  DemGrid elevation;  // nodata where not kriged
  DemGrid sigma;      // kriging standard deviation, metres
  VariogramModel model;
  ExperimentalVariogram experimental;
  double max_gap_m = 0.0;  // the gap limit used
  double sigma_scale = 1.0;  // leave-one-out calibration factor applied to the kriging sigma
  long long cells_kriged = 0;
  double variogram_seconds = 0.0;
  double kriging_seconds = 0.0;
  int threads = 1;                     // threads used for the cells
  long long factorisations = 0;        // covariance blocks factorised (grid cells; LOO calibration apart)
  long long factorisation_reuses = 0;  // cells that reused the previous cell's (same neighbour set)
};

// `grid` gives the geometry (east0, north0, cell, cols, rows, nodata); its values are ignored.
// Throws std::invalid_argument on an empty cloud or a bad grid.
KrigingResult krigeDem(const std::vector<DemPoint>& points, const DemGrid& grid, const KrigingOptions& options);

// A grid covering the points' bounding box (plus a margin of one cell) at `cell_m`.
DemGrid gridAround(const std::vector<DemPoint>& points, double cell_m);

}  // namespace areomap::dem
