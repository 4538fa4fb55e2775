// The scratch that the fast adjuster's solvers share (FastAdjuster.hpp): the per-image observation index,
// the observation rows of the last linearisation, the points' 3x3 blocks, the pairs' 12x12 blocks, the
// cameras' step of a linear solve and one pool of 12x12 / 12x3 blocks. The adjuster owns one and passes it by
// reference to the reduced camera system (ReducedCameraSystem.hpp), the block Cholesky (BlockCholesky.hpp),
// PCG (PcgSolver.hpp) and the alternation (Alternation.hpp); what only one solver needs lives in that
// solver. Fixed arrays sized by Capacities.hpp (~15 MiB at full capacity with the solvers' own state):
// allocate it once, e.g. as a member of a static object.
#pragma once

#include <cstdint>

#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"

namespace areomap {

constexpr int32_t kMaxEoUnknowns = 6 * kMaxImages;
// kSchurCholesky: 12x12 blocks of the RCS factor (diagonal + structural non-zeros below it, fill included).
// A two-tier ring of 64 pairs needs a few hundred; 2048 also holds 64 fully coupled pairs (64*65/2). The
// pool shares its memory with the alternation's per-point coupling blocks (same size, never both in use).
constexpr int32_t kMaxFactorBlocks = 2048;

struct AdjustWorkspace {
  // Builds the per-image observation index below from the network's observations.
  void buildImageIndex(const Network& net);

  // The observations of image i: image_obs[image_obs_start[i] .. image_obs_start[i + 1]).
  int32_t image_obs_start[kMaxImages + 1] = {};
  int32_t image_obs[kMaxObservations] = {};
  // Per pair: its damped 12x12 normal block with constraints (kSchurPcg and the covariance's PCG columns).
  Mat12 pair_normal[kMaxPairs];

  // The step of the cameras (6 per image, [dC, delta]) of the last linear solve (PCG or block Cholesky).
  double step[kMaxEoUnknowns] = {};
  // The rejection's robust scale: the absolute whitened residual coordinates.
  double scratch[2 * kMaxObservations] = {};

  // Per point, from pointBlocks(): its 3x3 inverse normal block and right-hand side; `mark` holds the last
  // pair that touched a point, `touched` the points of the pair being assembled.
  Mat3 point_inverse[kMaxTiePoints];
  Vec3 point_rhs[kMaxTiePoints];

  // The alternation's and PCG's coupling W (12x3) of the pair being assembled to each of its points, OR
  // (kSchurCholesky) the pool of 12x12 factor blocks: one buffer, the two are never in use at the same time.
  static constexpr int32_t kPoolDoubles =
      36 * kMaxTiePoints > 144 * kMaxFactorBlocks ? 36 * kMaxTiePoints : 144 * kMaxFactorBlocks;
  alignas(64) double pool[kPoolDoubles] = {};
  Eigen::Map<Mat12x3, Eigen::Aligned16> coupling(int32_t point) {
    return Eigen::Map<Mat12x3, Eigen::Aligned16>(pool + 36 * point);
  }
  Eigen::Map<const Mat12x3, Eigen::Aligned16> coupling(int32_t point) const {
    return Eigen::Map<const Mat12x3, Eigen::Aligned16>(pool + 36 * point);
  }
  Eigen::Map<Mat12, Eigen::Aligned16> poolBlock(int32_t slot) {
    return Eigen::Map<Mat12, Eigen::Aligned16>(pool + 144 * slot);
  }
  Eigen::Map<const Mat12, Eigen::Aligned16> poolBlock(int32_t slot) const {
    return Eigen::Map<const Mat12, Eigen::Aligned16>(pool + 144 * slot);
  }

  bool point_eliminated[kMaxTiePoints] = {};
  int32_t mark[kMaxTiePoints] = {};
  int32_t touched[kMaxTiePoints] = {};
  // Per observation, from linearize() (a pair's own observations do not change until the pair is solved):
  // whitened residual and Jacobians (~10 MiB at full capacity).
  Vec2 obs_residual[kMaxObservations];
  Mat2x6 obs_d_image[kMaxObservations];
  Mat2x3 obs_d_point[kMaxObservations];
  bool obs_valid[kMaxObservations] = {};
};

}  // namespace areomap
