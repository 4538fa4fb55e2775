// kSchurCholesky's linear solver: the damped reduced camera system S = C - W N^-1 W^T
// (ReducedCameraSystem.hpp) assembled in 12x12 pair blocks and factorised directly, S = L L^T, by a
// right-looking block Cholesky. The pairs are eliminated in a minimum-degree order of the pair graph (two
// pairs are adjacent when they observe a common solvable point), which keeps the fill of a panorama ring
// small; the factor's blocks live in the workspace's pool of kMaxFactorBlocks 12x12 blocks
// (AdjustWorkspace::poolBlock). A network whose factor does not fit the pool is reported by order(), and the
// caller solves it by PCG instead.
#pragma once

#include <cstdint>

#include "firmware_core/adjust/AdjustWorkspace.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"

namespace areomap {

class BlockCholesky {
 public:
  // The pair graph, a minimum-degree elimination order of it (ties: the lower pair index, i.e. the panorama
  // order) and the block pattern of the factor in that order, fill included (the elimination graph). False
  // when the factor needs more than kMaxFactorBlocks blocks.
  bool order(const Network& net);
  // 12x12 blocks of the factor found by the last order() (diagonal included).
  int32_t factorBlocks() const { return factor_blocks_; }

  // The damped RCS (rhs v = g - W N^-1 b) from the observation rows of the last linearize(), in the
  // factor's pattern, then its factor in place. False when S is not positive definite at this damping.
  bool assembleAndFactor(const Network& net, AdjustWorkspace& ws, double damping);
  // S itself (no damping, no regularisation), for the EO covariance.
  bool assembleAndFactorUndamped(const Network& net, AdjustWorkspace& ws);

  // L L^T x = v by block forward and back substitution; the cameras' step into ws.step (per image).
  void solve(const Network& net, AdjustWorkspace& ws);

  // The 12 columns of S^-1 that belong to pair `pair`: x[j] = the 12x12 block (pair j's rows, `pair`'s
  // columns), by pair index, from the factor of the last assembleAndFactor() (EoCovariance.hpp).
  void solvePairColumns(const Network& net, const AdjustWorkspace& ws, int32_t pair, Mat12* x) const;

 private:
  Eigen::Map<Mat12, Eigen::Aligned16> block(AdjustWorkspace& ws, int32_t row, int32_t col) const {
    return ws.poolBlock(block_pos_[row][col]);
  }
  // The points' blocks damped by `damping`, the pairs' diagonals multiplied by `diagonal_factor`.
  void assemble(const Network& net, AdjustWorkspace& ws, double damping, double diagonal_factor);
  bool factor(int32_t n, AdjustWorkspace& ws);

  // The pairs' elimination order (order_[k] = pair, position_[pair] = k), the factor's pattern
  // (block_pos_[row][col] = pool slot for row >= col in that order, -1 = structural zero; column k's rows
  // below the diagonal in col_rows_[col_start_[k] .. col_start_[k+1])), the pair graph used to find it, and
  // the RCS right-hand side / solution (12 per pair, in elimination order).
  int32_t order_[kMaxPairs] = {};
  int32_t position_[kMaxPairs] = {};
  int16_t block_pos_[kMaxPairs][kMaxPairs] = {};
  int32_t col_start_[kMaxPairs + 1] = {};
  int16_t col_rows_[kMaxFactorBlocks] = {};
  bool graph_[kMaxPairs][kMaxPairs] = {};
  int32_t factor_blocks_ = 0;
  double rhs_[12 * kMaxPairs] = {};
};

}  // namespace areomap
