// An error that every point of a stereo pair takes from its cameras: the adjusted exterior orientation is
// known only to its covariance (ground/adjust/FullEoCovariance.hpp), and an EO error e_p of pair p moves
// the height of each of its points at x by g_p(x) . e_p (12 unknowns per pair, Constraints.hpp's order).
// No neighbourhood averages it down, and it is correlated between pairs: a panorama's pairs share modes
// that the ties fix weakly (a common vergence of every pair moves every pair's heights the same way at one
// range), so where pairs overlap their errors do not average either. The kriged height of a cell,
// sum_i w_i z_i with point i made of pair p's points in the fraction a_ip, takes
//     e = sum_p W_p g_p(x) . e_p,   W_p = sum_i w_i a_ip,
// whose variance h^T C h (h_p = W_p g_p(x), C the EO covariance) the cell's sigma adds (Kriging.hpp).
// g_p is evaluated at the cell (it changes over metres, the neighbourhood spans centimetres).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace areomap::dem {

inline constexpr int kSharedErrorDims = 12;  // a pair's EO: [left dC, delta, right dC, delta]
inline constexpr int kMaxPointPairs = 4;     // pairs kept per binned point (its largest shares)

// Which pairs make a (binned) point, and in which fractions a_ip (summing to 1). Pair: dense::linePair.
struct PointPairs {
  int32_t pair[kMaxPointPairs] = {-1, -1, -1, -1};
  float fraction[kMaxPointPairs] = {0.f, 0.f, 0.f, 0.f};
};

struct SharedHeightError {
  std::map<int64_t, int> block_of_pair;  // pair id -> its block in `covariance`
  Eigen::MatrixXd covariance;            // kSharedErrorDims per block, square
  // d(height up) / d e_p at a site-frame point (north, east, elevation up) for block `block`; false where
  // the pair does not see it (the block then adds nothing). Called from several threads at once.
  std::function<bool(int block, double north_m, double east_m, double elevation_m, double* g)> gradient;

  // The variance of a cell's height from the weights `w` of its f neighbours `idx` (their pairs in
  // `pairs`), at the cell (north, east, elevation).
  double cellVariance(const std::vector<PointPairs>& pairs, int f, const int32_t* idx, const double* w,
                      double north_m, double east_m, double elevation_m) const;
};

}  // namespace areomap::dem
