#include "ground/dem/SharedHeightError.hpp"

#include <cmath>

namespace areomap::dem {

double SharedHeightError::cellVariance(const std::vector<PointPairs>& pairs, int f, const int32_t* idx,
                                       const double* w, double north_m, double east_m,
                                       double elevation_m) const {
  // W_p per pair of the neighbourhood (a few: the neighbours of one cell come from one to four pairs).
  constexpr int kMaxCellPairs = 16;
  int32_t pair_of[kMaxCellPairs];
  double weight_of[kMaxCellPairs];
  int count = 0;
  for (int i = 0; i < f; ++i) {
    const PointPairs& pp = pairs[static_cast<std::size_t>(idx[i])];
    for (int k = 0; k < kMaxPointPairs && pp.pair[k] >= 0; ++k) {
      int slot = 0;
      while (slot < count && pair_of[slot] != pp.pair[k]) ++slot;
      if (slot == count) {
        if (count == kMaxCellPairs) continue;  // not reached: a cell's 16-64 neighbours see few pairs
        pair_of[count] = pp.pair[k];
        weight_of[count++] = 0.0;
      }
      weight_of[slot] += w[i] * pp.fraction[k];
    }
  }
  Eigen::Matrix<double, kSharedErrorDims, 1> h[kMaxCellPairs];
  int block[kMaxCellPairs];
  int used = 0;
  for (int s = 0; s < count; ++s) {
    const auto it = block_of_pair.find(pair_of[s]);
    if (it == block_of_pair.end() || weight_of[s] == 0.0) continue;
    double g[kSharedErrorDims];
    if (!gradient(it->second, north_m, east_m, elevation_m, g)) continue;
    for (int d = 0; d < kSharedErrorDims; ++d) h[used](d) = weight_of[s] * g[d];
    block[used++] = it->second;
  }
  double var = 0.0;
  for (int a = 0; a < used; ++a) {
    for (int b = 0; b < used; ++b) {
      var += h[a].dot(covariance.block<kSharedErrorDims, kSharedErrorDims>(kSharedErrorDims * block[a],
                                                                           kSharedErrorDims * block[b]) *
                      h[b]);
    }
  }
  return std::isfinite(var) ? std::max(0.0, var) : 0.0;
}

}  // namespace areomap::dem
