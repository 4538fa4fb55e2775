// kSchurPcg's linear solver (and kSchurCholesky's when the factor does not fit its pool): the damped reduced
// camera system S x = v (ReducedCameraSystem.hpp) solved by conjugate gradients, preconditioned by the
// pairs' reduced 12x12 blocks (block Jacobi), S applied matrix-free through the cached observation rows.
#pragma once

#include <cstdint>

#include "firmware_core/adjust/AdjustWorkspace.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"

namespace areomap {

constexpr int32_t kMaxPcgIterations = 200;  // conjugate-gradient steps per linearisation

class PcgSolver {
 public:
  // The LM step at `damping` from the observation rows of the last linearize(): the cameras' step into
  // ws.step (per image), from x = 0 until |r| <= relative_tolerance |v| or kMaxPcgIterations. Adds the
  // conjugate-gradient steps taken to `iterations`. Leaves ws.pair_normal (the damped pair blocks) and the
  // point blocks for the back-substitution.
  void solve(const Network& net, AdjustWorkspace& ws, double relative_tolerance, double damping,
             int32_t& iterations);

  // S x = v for any right-hand side v (6 per image) with the system of the last prepare(): the EO
  // covariance's columns when the block Cholesky factor does not fit its pool (EoCovariance.hpp). S is
  // that of prepareUndamped(): no damping, no regularisation.
  void prepareUndamped(const Network& net, AdjustWorkspace& ws) { eliminatePoints(net, ws, 0.0, 1.0); }
  void solveReduced(const Network& net, const AdjustWorkspace& ws, const double* v, double relative_tolerance,
                    double* x, int32_t& iterations);

 private:
  // The points' blocks damped by `damping`, the pairs' diagonals multiplied by `diagonal_factor`.
  void eliminatePoints(const Network& net, AdjustWorkspace& ws, double damping, double diagonal_factor);
  // Conjugate gradients from x = 0 for the right-hand side in r_.
  void iterate(const Network& net, const AdjustWorkspace& ws, double relative_tolerance, double* x,
               int32_t& iterations);

  // The pairs' reduced inverses (the preconditioner) and the conjugate-gradient vectors (6 per image).
  Mat12 pair_inverse_[kMaxPairs];
  double r_[kMaxEoUnknowns] = {};
  double z_[kMaxEoUnknowns] = {};
  double p_[kMaxEoUnknowns] = {};
  double q_[kMaxEoUnknowns] = {};
};

}  // namespace areomap
