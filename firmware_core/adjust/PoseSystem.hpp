// The reduced system of the multi-site adjustment (SitePoseAdjuster.hpp): symmetric, over the free sites'
// 6-DOF pose updates, dense in 6x6 blocks (every cross-site point couples the sites that see it, the
// odometry legs couple neighbours; at kMaxSites a dense factor is cheap: 32^3/6 block products), factorised
// by a block Cholesky with Marquardt damping on the diagonal. Fixed memory: the system and its factor,
// 2 x kMaxSites^2 blocks of 288 bytes (576 KiB at 32 sites), no heap, bounded loops.
#pragma once

#include <cstdint>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"

namespace areomap {

// kSites: the most blocks (kMaxSites on the rover, kMaxGroundSites on the ground; both instantiated in
// PoseSystem.cpp).
template <int32_t kSites>
class PoseSystem {
 public:
  static_assert(kSites >= 1, "a system of at least one block");

  // Zeroes an n x n block system (n <= kSites) and its right-hand side.
  void reset(int32_t n);
  int32_t size() const { return n_; }

  // Adds `block` at (i, j) (and its transpose at (j, i)); i == j adds a diagonal block.
  void add(int32_t i, int32_t j, const Mat6& block);
  Vec6& rhs(int32_t i) { return rhs_[i]; }
  const Vec6& rhs(int32_t i) const { return rhs_[i]; }
  const Mat6& block(int32_t i, int32_t j) const { return i >= j ? s_[i][j] : s_[j][i]; }

  // Factorises S + damping diag(S) (damping >= 0); false when it is not positive definite.
  [[nodiscard]] bool factor(double damping);
  // x = (damped S)^-1 rhs from the last factor (n blocks of 6 each).
  void solve(Vec6* x) const;
  // The 6x6 diagonal block (k, k) of (damped S)^-1 from the last factor.
  Mat6 inverseDiagonalBlock(int32_t k);

 private:
  Mat6 s_[kSites][kSites];  // lower triangle (i >= j)
  Mat6 l_[kSites][kSites];  // Cholesky factor, lower triangle
  Vec6 rhs_[kSites];
  Mat6 work_[kSites];
  int32_t n_ = 0;
};

extern template class PoseSystem<kMaxSites>;
extern template class PoseSystem<kMaxGroundSites>;

}  // namespace areomap
