// The a-posteriori covariance of the exterior orientation, the precision of an adjusted network (§3.5): for
// every stereo pair the 12x12 block [left 6, right 6] (unknowns [dC (m), delta (rad, camera frame)] of
// Constraints.hpp) of
//     sigma0^2 S^-1 (S - P) S^-1,
// where S is the reduced camera system at the solution, linearised there, undamped: every ground point
// eliminated by its 3x3 block (its uncertainty carried into the cameras', not held fixed), the rig
// constraints of Eq. 3 and Eq. 4 in. P is the part of S from rows that are no measurement
// (Constraints.hpp isMeasurement): the datum prior (RigConstraints::sigma_datum_rad), which only chooses
// which of the free network's solutions is kept (the common rotation at the mean a-priori pointing), and
// the rows of held rig constraints, whose sigma only makes the given rig values hold (Network.hpp). Their
// information is taken out of the middle of the sandwich, so what is left is the covariance of the
// solution's scatter under the images' noise (and the noise of rig values whose sigmas the dataset gave),
// in the datum in which every comparison with truth is made (DESIGN.md "Datum": the common rotation
// removed).
//
// S^-1 is taken pair by pair: the 12 columns of a pair come from the block Cholesky factor of S
// (BlockCholesky.hpp) by one block forward and back substitution, or, for a network whose factor does not
// fit the pool, by 12 preconditioned conjugate-gradient solves (PcgSolver.hpp). With the pair's column
// block X_p (all pairs' rows): C_pp = sigma0^2 (X_p[p] - sum_j (J_j X_p[j])^T (J_j X_p[j])) with J_j pair
// j's rows that are no measurement (P_j = J_j^T J_j).
//
// Fixed memory (one 12x12 block per pair of scratch), no heap, bounded loops.
#pragma once

#include <cstdint>

#include "firmware_core/adjust/AdjustWorkspace.hpp"
#include "firmware_core/adjust/BlockCholesky.hpp"
#include "firmware_core/adjust/Constraints.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/adjust/PcgSolver.hpp"
#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/Status.hpp"

namespace areomap {

enum class CovarianceSolver : uint8_t { kNone = 0, kCholesky = 1, kPcg = 2 };

// Receives, pair after pair, the 12 columns of S^-1 that belong to that pair (every pair's rows, by pair
// index, unscaled), as EoCovariance::compute takes them: what a caller needs for the covariance between
// pairs, which the per-pair blocks do not keep (the ground assembles the whole matrix from them:
// ground/adjust/FullEoCovariance.hpp). Nothing is kept after the call.
class CovarianceColumnSink {
 public:
  virtual void pairColumns(int32_t pair, const Mat12* columns, int32_t pair_count) = 0;

 protected:
  ~CovarianceColumnSink() = default;
};

// Relative residual of the conjugate-gradient columns (the fallback): far below the 1e-8 that an LM step
// needs, so that the sigmas agree with the factor's to ~1e-6.
constexpr double kCovariancePcgTolerance = 1e-12;

// The redundancy of the network at its current state with `active_observations` observations in front of
// their cameras: 2 per observation + the constraint rows - 6 per image - 3 per solvable point; the datum
// prior's rows are not counted as observations (they fix the datum's 3 rotations).
int32_t networkRedundancy(const Network& net, int32_t active_observations);

// Stores a pair's covariance (a single image's right half zeroed) and its images' sigmas, the square roots
// of its diagonal: what every path that computes an EO covariance writes into the network.
void setPairCovariance(Network& net, int32_t pair, const Mat12& covariance);

class EoCovariance {
 public:
  // Writes every pair's covariance (NetPair::covariance) and every image's sigmas (NetImage::sigma, the
  // square roots of its diagonal) at the network's current state, scaled by sigma0^2. The workspace's image
  // index must be built (FastAdjuster::checkNetwork). kDegenerate when S is not positive definite,
  // kNotFinite when a covariance is not finite; `solver` says which solver gave the columns (the factor
  // when it fits its pool, unless `use` is kPcg). `sink` (optional) is handed each pair's columns.
  [[nodiscard]] Status compute(Network& net, AdjustWorkspace& ws, BlockCholesky& cholesky, PcgSolver& pcg,
                               double sigma0, CovarianceSolver& solver,
                               CovarianceSolver use = CovarianceSolver::kCholesky,
                               CovarianceColumnSink* sink = nullptr);

 private:
  void pcgColumns(const Network& net, const AdjustWorkspace& ws, PcgSolver& pcg, int32_t pair);
  void store(Network& net, int32_t pair, double sigma0) const;

  Mat12 columns_[kMaxPairs];                  // the 12 columns of S^-1 of one pair, by pair index (rows)
  ConstraintJacobian fixed_rows_[kMaxPairs];  // each pair's rows that are no measurement, packed at the top
  int32_t fixed_count_[kMaxPairs] = {};
  double v_[kMaxEoUnknowns] = {};
  double x_[kMaxEoUnknowns] = {};
};

}  // namespace areomap
