// The dense cloud binned to DEM cells for kriging (paper 4.1): one point per cell (mean position and height,
// sigma of the mean), with what the DEM sigma (Kriging.hpp) needs besides: each bin's ground sample distance
// and the relief inside it that its mean does not carry, and the fraction of the points' noise that does
// not average down (errors one pair's points share over a wide part of its view), measured where two pairs
// see the same ground, and carried into the kriging as an error the pair's neighbouring cells share.
#pragma once

#include <functional>
#include <vector>

#include "ground/dataset/DemRaster.hpp"
#include "ground/dem/Kriging.hpp"
#include "ground/dem/PackedCloud.hpp"
#include "ground/dem/SharedHeightError.hpp"

namespace areomap::dem {

// The cloud binned to DEM cells (mean height, sigma of the mean) so that kriging sees one point per cell;
// only the points for which keep(p) holds (no copy of the cloud for a subset).
// The mean's sigma: the points of one pair in a cell are n_p neighbouring pixels of one image, whose match
// errors are correlated (dense::kMatchErrorCorrelationPx, exp(-lag / L)); the cell is taken as a square
// patch of sqrt(n_p) x sqrt(n_p) pixels, so Var(the pair's mean) = s_p^2 patchVarianceFactor(sqrt(n_p), L)
// (s_p^2 the points' mean sigma^2); pairs are independent: Var(mean) = sum_p (n_p / n)^2 Var(pair's mean).
// The cell's ground sample distance (gsd_m, what the kriging's error correlation needs): cell / sqrt(n_p)
// of the pair with the most points there (the ground size of one of its pixels).
// The cell's representation variance (rep_var_m2, KrigingOptions::point_extra_var_m2): the mean height
// stands for the surface at the bin's centroid, and what the surface does inside the bin beyond a plane
// is not in it. Measured from the bin's own points: the variance of their heights about their
// least-squares plane, less what the points' noise puts there (s^2 (1 - patchVarianceFactor) per pair, the
// part of correlated errors that does not move the bin's mean); 0 for bins of fewer than
// kMinRepresentationPoints points.
// The cell's pair-wide error (pair_sd_m, KrigingOptions::point_pair_sd_m): phi's part of Var(mean), which
// the same pair's neighbouring cells share.
struct BinnedCloud {
  std::vector<DemPoint> points;
  std::vector<float> gsd_m;            // per point
  std::vector<float> rep_var_m2;       // per point
  std::vector<float> pair_sd_m;        // per point: the part of sigma its pair shares (KrigingOptions)
  std::vector<PointPairs> pairs;       // per point: its pairs and their shares of its points
  double shared_noise_fraction = 0.0;  // phi of sharedNoiseFraction
  long long overlap_bins = 0;          // the bins it was measured on
  double common_error_correlation = 0.0;  // rho of commonErrorCorrelation: two pairs' errors in one bin
  long long binned_points = 0;            // the cloud's points in the bins (every one that keep accepts)
};

// The cloud summed into bins (sumBins), before what only every bin together gives (phi and rho of
// BinnedCloud) is known: per cell its points' mean and its relief, per pair slot in the cell that pair's
// points and their summed noise variance, and the cells two pairs share (sharedNoiseFraction,
// commonErrorCorrelation); by bands of grid rows. Holds nothing of the cloud, so that the cloud is freed
// before finishBins.
struct BinSums {
  struct Cell {
    double north_m, east_m, elevation_m;  // the mean of its points
    double n;                             // its points
    float rep_var_m2;
    uint32_t pair_count;  // its pair slots, the next ones of its band's pair_sums
  };
  struct PairSum {
    double n, s2;  // the pair slot's points in the cell, the sum of their sigma^2
    int64_t slot;
  };
  struct Band {
    std::vector<Cell> cells;  // in the order of their rows, columns
    std::vector<PairSum> pair_sums;
  };
  // A cell that two pairs see with at least kMinOverlapPoints points each (BinnedCloud.cpp overlapBins).
  struct Overlap {
    long long cell, slot_p, slot_q;
    double d, mean_var_p, mean_var_q, factor_p, factor_q;
  };
  std::vector<Band> bands;  // in the order of their rows
  std::vector<Overlap> overlaps;
  long long binned_points = 0;  // every point that keep accepts
};

// Sums the points of `cloud` for which keep(p) holds (no copy of the cloud for a subset) into the cells
// of `grid`, a band of the grid's rows at a time (only one band's bins held with their full sums);
// correlation_px: the matcher's error correlation length in pixels (exp(-lag / L)).
BinSums sumBins(const PackedCloud& cloud, const DemGrid& grid,
                const std::function<bool(const DemPoint&)>& keep, double correlation_px);
// The binned cloud of `sums` (taken over: freed as the result is made) on a grid of cell_m.
BinnedCloud finishBins(BinSums sums, double cell_m, double correlation_px);
// finishBins(sumBins(...)).
BinnedCloud binPoints(const PackedCloud& cloud, const DemGrid& grid,
                      const std::function<bool(const DemPoint&)>& keep, double correlation_px);

// Kriging of a binned cloud with the matcher's error correlation (the DEM sigma of Kriging.hpp), and the
// cameras' shared error when `shared` is given.
KrigingOptions binnedKrigingOptions(const BinnedCloud& binned, const DemGrid& grid, double correlation_px,
                                    const SharedHeightError* shared = nullptr);

}  // namespace areomap::dem
