// Ordinary kriging of a point cloud onto a DEM grid (paper §4.1): the fitted variogram (Variogram.hpp),
// the k nearest points of each cell from a k-d tree, one (k+1)x(k+1) solve per cell, and the kriging
// standard deviation as a second raster (dem_sigma.tif). A cell is kriged when a point lies within the gap
// limit and one such point belongs to a cluster of at least k points (KrigingOptions::min_cluster_points).
//
// The kriging is "filtered": the nugget and each point's own sigma are treated as measurement noise, so
// the estimate is that of the noise-free surface. Its sigma, with independent point errors: the kriging
// variance, calibrated by leave-one-out cross-validation on a sample of points (sigma_scale). With
// correlated point errors (dense matches; KrigingOptions::noise_correlation_px): the variance of the
// estimate's error under a model of both parts, the surface between the points (the signal variogram:
// the robust experimental variogram less the points' noise) and the points' errors averaged with their
// correlation (checked per range band against truth: tests/ground/products/NavcamAccuracyTest.cpp and
// tests/ground/products/calibration).
// Grids are ground/dataset's DemGrid
// (north-up, columns east = site +Y, rows south = site -X, elevation up = -Z).
#pragma once

#include <cstdint>
#include <vector>

#include "ground/dataset/DemRaster.hpp"
#include "ground/dem/SharedHeightError.hpp"
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
  // Cells farther than this from every point stay nodata (-1: automatic, three times the cloud's median
  // point spacing, the distance to a point's 8th nearest, itself counted).
  double max_gap_m = -1.0;
  // With the automatic gap: each point reaches three times its own spacing, at least the cloud's gap. A
  // stereo cloud thins out with range (one image row spans range^2 / (camera height x focal length) of
  // ground), so one reach for the whole grid, set by the dense near points, leaves the far ground between
  // rows of points empty. A cell is kriged when it lies within the reach of a point that the support rule
  // below accepts.
  bool local_reach = true;
  // Support: points at most max_gap apart are linked, and linked points form one cluster (single linkage,
  // PointClusters.hpp); a cell is kriged only when one of its k neighbours within max_gap belongs to a
  // cluster of at least min_cluster_points.
  // -1: the neighbourhood size k (a smaller cluster cannot fill a cell's neighbourhood by itself: every
  // estimate there draws on points beyond the gap, where there is no data, so a lone far point or a small
  // clump would be spread into a disc of radius max_gap); 1: every point supports (no rule). Clamped to
  // the cloud's size. The points of small clusters still count as data for the cells of others.
  int min_cluster_points = -1;
  double max_lag_m = -1.0;       // variogram extent (-1: 6 neighbourhood radii, at most 1/3 of the cloud)
  bool use_point_sigma = true;   // point sigmas enter the diagonal (at least the nugget)
  const VariogramModel* model = nullptr;  // given model instead of the fitted one
  // Correlated point errors (dense matches share their matching footprint in the image). With
  // noise_correlation_px = L > 0 and a ground sample distance per point (point_gsd_m[i]: the ground size of
  // one image pixel at point i), the sigma of a cell is that of the estimate's error,
  //   Var = interpolation variance (filtered kriging: the noise-free surface) + Var(sum_i w_i e_i),
  //   Cov(e_i, e_j) = s_i s_j rho_ij,  s_i^2 = the point's noise variance (max(nugget, sigma^2)),
  // rho_ij = patchCorrelation(...) of the two points' separation in pixels; bin_cell_m > 0 says that each
  // point is the mean of the dense points in a square bin of that size (its sigma already that of the mean),
  // 0 that points are single pixels. L = 0 (or no gsd): errors independent, Var = the kriging variance.
  double noise_correlation_px = 0.0;
  const std::vector<float>* point_gsd_m = nullptr;
  double bin_cell_m = 0.0;
  // An error of each point that its neighbours do not share and that the kriging weights leave as it is
  // (variance m^2 per point, with point_gsd_m): the sigma adds sum_i w_i^2 v_i. The binned points' own
  // representation error: a bin's mean height stands for the surface at its centroid, and the surface's
  // relief inside the bin, beyond a plane, is what the mean does not carry (Products.cpp binPoints).
  const std::vector<float>* point_extra_var_m2 = nullptr;
  // A part of each point's error that the other points of its pair share (standard deviation c_i per point,
  // within its sigma: s_i^2 = sigma_i^2 - c_i^2 is the rest; with point_gsd_m): errors that change only
  // over a pair's whole view, such as the sub-pixel error's dependence on the disparity's fractional part
  // on smooth ground. Cov(e_i, e_j) = s_i s_j rho_ij + c_i c_j for points of one pair, so no neighbourhood
  // averages it down. The binned points' c_i: BinnedCloud::pair_sd_m.
  const std::vector<float>* point_pair_sd_m = nullptr;
  // The cameras' error that every point of a pair shares, correlated between pairs (SharedHeightError.hpp;
  // with point_pairs, each point's pairs): the sigma adds its variance at each cell, unscaled.
  const std::vector<PointPairs>* point_pairs = nullptr;
  const SharedHeightError* shared_error = nullptr;
  int threads = 0;  // threads for the cells (0: cli::threadCount()); the result is the same for any number
  // Per cell of the grid (row-major, cols x rows): 0 where the caller discards the cell's value (left
  // nodata, not searched), else kriged as usual; none: every cell. A cell's value does not depend on which
  // others are kriged, so the wanted cells are the same as without the mask.
  const std::vector<uint8_t>* cells = nullptr;
};

inline constexpr int kMaxKrigingThreads = 64;

inline constexpr int kMaxNeighbours = 64;

struct KrigingResult {
  DemGrid elevation;  // nodata where not kriged
  DemGrid sigma;      // kriging standard deviation, metres
  VariogramModel model;
  ExperimentalVariogram experimental;
  // With correlated point errors (KrigingOptions::noise_correlation_px): the variogram of the noise-free
  // surface (the experimental one less the points' noise semivariances) that the sigma uses.
  VariogramModel signal_model;
  ExperimentalVariogram signal_experimental;
  double max_gap_m = 0.0;  // the gap limit used
  double max_local_gap_m = 0.0;  // the largest point reach (KrigingOptions::local_reach; 0: none)
  int min_cluster_points = 1;       // the support rule used (KrigingOptions::min_cluster_points)
  long long isolated_points = 0;    // points in clusters smaller than that
  long long cells_unsupported = 0;  // wanted cells within max_gap of a point, left nodata by the support rule
  double sigma_scale = 1.0;  // leave-one-out calibration factor applied to the kriging sigma
  long long cells_kriged = 0;
  double variogram_seconds = 0.0;
  double kriging_seconds = 0.0;
  int threads = 1;                     // threads used for the cells
  long long factorisations = 0;        // covariance blocks factorised (grid cells; LOO calibration apart)
  long long factorisation_reuses = 0;  // cells that reused the previous cell's (same neighbour set)
};

// Mean correlation of the errors of a square patch of m x m pixels (m >= 1, real), pixel errors correlated
// as exp(-|dx| / L) exp(-|dy| / L): the variance of the patch mean is sigma^2 * patchVarianceFactor(m, L).
double patchVarianceFactor(double m_px, double l_px);
// Correlation of the means of two such patches (m x m pixels each) whose centres are dx, dy pixels apart.
double patchCorrelation(double dx_px, double dy_px, double m_px, double l_px);
// The same with q = exp(-1 / l_px) given (for l_px > 0): a caller with one L computes it once.
double patchCorrelation(double dx_px, double dy_px, double m_px, double l_px, double q);

// `grid` gives the geometry (east0, north0, cell, cols, rows, nodata); its values are ignored.
// Throws std::invalid_argument on an empty cloud, a bad grid or a cell mask not of its size.
KrigingResult krigeDem(const std::vector<DemPoint>& points, const DemGrid& grid, const KrigingOptions& options);

// A grid covering the points' bounding box (plus a margin of one cell) at `cell_m`.
DemGrid gridAround(const std::vector<DemPoint>& points, double cell_m);

}  // namespace areomap::dem
