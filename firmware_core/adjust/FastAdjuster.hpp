// The fast constrained bundle adjustment (Di, Xu, Li §3.3). The paper's structure — a 12x12 normal block per
// stereo pair (6x6 for a single image) and a 3x3 block per ground point — is kept by every method here; they
// differ in how the coupled system is solved:
//   kSchurCholesky (default, fastest at equal accuracy, BENCHMARKS.md): Levenberg-Marquardt whose step
//     eliminates every point with its 3x3 block, assembles the pairs' 12x12 blocks of the reduced camera
//     system (RCS; block-sparse: pairs that share points) and factorises it directly by a block Cholesky in
//     a fixed pool of kMaxFactorBlocks 12x12 blocks, pairs in a minimum-degree order of the pair graph. A
//     network whose factor does not fit the pool is solved by kSchurPcg instead (counted in the result).
//   kSchurPcg: the same LM, the RCS solved by conjugate gradients with the pairs' reduced 12x12 blocks as
//     block-Jacobi preconditioner.
//   kGaussSeidelAnderson: nonlinear block Gauss-Seidel on the reduced camera system — pair after pair, the
//     pair's 12x12 block with its points eliminated (the other pairs fixed), then the points back-
//     substituted by their 3x3 blocks — with the sweep map Anderson-accelerated over the stacked EO vector
//     in the tangent space (fixed-size history; the extrapolated EO is kept only if the total weighted
//     cost goes down, else the plain sweep is taken).
//   kPaperAlternation: the paper's §3.3 step as written — every pair's 12x12 EO solve with the points
//     fixed, then every point's 3x3 solve with the EO fixed, repeated until the stop rule. No elimination,
//     no acceleration: it stalls on a panorama (shared/reference/fast-adjustment.md) and is here so that
//     the paper's method itself can be run and measured.
//
// Stop rule (both must hold): the total weighted cost changed by less than `relative_cost_tolerance`
// (relative, in absolute value) over the last `window` sweeps (kSchurCholesky: over its last accepted step,
// its convergence is quadratic) AND the largest EO update of the last sweep is below `eo_step_tolerance_px`
// (pixel equivalent, see eoPixelEquivalent). Otherwise the sweep bound fires.
//
// Held rig sigmas (RigConstraints::hold_*, Network.hpp): after the rejection rounds, while a held
// constraint's largest misfit exceeds half of kRigMisfitBound_m its sigma is tightened and the network
// solved again from where it is (at most kMaxRigTightenings times; counted in the result).
//
// Robust rejection: after a converged solve the whitened residual norms are compared with
// max(reject_k x 1.4826 MAD, reject_floor_sigma); per point only the worst observation above it is
// rejected per round (a point left with < 2 rays becomes unsolvable), and the solve is repeated, at most
// kMaxRejectionRounds times. Every rejection is counted.
//
// Where each part is: this class is the front (checks, the Levenberg-Marquardt loop of the two Schur
// methods, robust rejection, held-rig tightening, precision); options and result in FastAdjustOptions.hpp;
// the point and pair blocks and the reduced camera system in ReducedCameraSystem.hpp; the RCS solvers in
// BlockCholesky.hpp and PcgSolver.hpp; the alternation and its Anderson accelerator in Alternation.hpp;
// the scratch they share in AdjustWorkspace.hpp.
//
// Memory: the workspace and the solvers live in the adjuster object (~15 MiB at full capacity: allocate it
// once, e.g. static); adjust() makes no heap allocation, throws nothing, and every loop is bounded by a
// named constant.
#pragma once

#include <cstdint>

#include "firmware_core/adjust/AdjustWorkspace.hpp"
#include "firmware_core/adjust/Alternation.hpp"
#include "firmware_core/adjust/BlockCholesky.hpp"
#include "firmware_core/adjust/Constraints.hpp"
#include "firmware_core/adjust/EoCovariance.hpp"
#include "firmware_core/adjust/FastAdjustOptions.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/adjust/PcgSolver.hpp"
#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/Status.hpp"

namespace areomap {

class FastAdjuster {
 public:
  // Checks that every image has enough rays of solvable points and that they are not all on a line, and
  // marks points with fewer than 2 active rays unsolvable. kDegenerate names the image in bad_image.
  [[nodiscard]] Status checkNetwork(Network& net, int32_t& bad_image);

  // Adjusts the network in place from its current EO and points (a warm start when called again after
  // adding pairs). EO sigmas are written into each NetImage.
  [[nodiscard]] Status adjust(Network& net, const FastAdjustOptions& options, FastAdjustResult& result);

  // The precision of the network as it stands (solved by any adjuster with the same observations and
  // rejection flags: the integrated ones on the ground): cost, redundancy, sigma0, rig misfits and the EO
  // covariance (EoCovariance.hpp) into every pair and image, as adjust() ends (a covariance that cannot be
  // had is said in result.covariance_status, not as a failure). Checks the network first.
  [[nodiscard]] Status precisionOf(Network& net, FastAdjustResult& result);

  // A caller's sink for the columns of S^-1 of every EO covariance computed from now on (nullptr: none).
  void setCovarianceSink(CovarianceColumnSink* sink) { covariance_sink_ = sink; }

  // Total weighted cost and image RMS of the current state, no update.
  double evaluateCost(const Network& net, double* rms_px = nullptr, int32_t* active = nullptr) const;

 private:
  // One solve of the network from its current state by the method of `options`.
  [[nodiscard]] Status solve(Network& net, const FastAdjustOptions& options, FastAdjustResult& result);
  [[nodiscard]] Status solveLm(Network& net, const FastAdjustOptions& options, FastAdjustResult& result);
  // Applies the cameras' step in ws_.step and back-substitutes the points; returns its largest EO update
  // (pixel equivalent). saveState() / restoreState() keep the state before it for a rejected step.
  double applyStep(Network& net, const FastAdjustOptions& options);
  void saveState(const Network& net);
  void restoreState(Network& net) const;
  int32_t rejectOutliers(Network& net, const FastAdjustOptions& options);
  // Sigma naught from the redundancy and, when asked, the EO covariance (points eliminated,
  // EoCovariance.hpp).
  [[nodiscard]] Status precision(Network& net, FastAdjustResult& result, bool eo_covariance);

  AdjustWorkspace ws_;
  BlockCholesky cholesky_;
  PcgSolver pcg_;
  Alternation alternation_;
  EoCovariance covariance_;
  CovarianceColumnSink* covariance_sink_ = nullptr;
  // The LM methods' state before a step, restored when the step does not lower the cost.
  Vec3 saved_centre_[kMaxImages];
  Mat3 saved_m_[kMaxImages];
  Vec3 saved_xyz_[kMaxTiePoints];
};

}  // namespace areomap
