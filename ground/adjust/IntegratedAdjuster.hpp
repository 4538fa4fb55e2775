// The integrated (simultaneous) constrained bundle adjustment, the ground-side reference of the fast
// adjuster (Di, Xu, Li §3.1-§3.2): all EO and ground unknowns at once, with exactly the observations,
// rejection flags, constraint rows and weights of firmware_core/adjust (Constraints.hpp), so that the
// solutions can be compared.
//   - adjustSvd: the paper's way. Gauss-Newton on the full dense normal matrix, each step solved by SVD
//     with the minimum-norm solution (singular values below 1e-12 x the largest are dropped: the free
//     network). For networks up to the paper's size (a few thousand unknowns).
//   - adjustCeres: sparse Schur-complement Levenberg-Marquardt (Ceres SPARSE_SCHUR, points eliminated),
//     cameras on the rotation manifold (the same local update M' = exp([delta]x) M).
// Both apply the held-sigma rule of Network.hpp (tighten and solve again) like the fast adjuster, and end
// with the solution's precision: sigma0 and the EO covariance (EoCovariance.hpp) in every pair and image,
// the SVD path from its own full normal matrix, the Ceres path from the reduced camera system there.
// Neither changes rejection flags; run the fast adjuster's rejection first (or pass a clean network).
#pragma once

#include <string>

#include "firmware_core/adjust/Network.hpp"

namespace areomap::ground {

struct IntegratedOptions {
  int max_iterations = 50;
  double eo_step_tolerance_px = 1e-7;  // stop when the largest EO step is below (pixel equivalent)
  double nominal_range_m = 5.0;
  bool dense_schur = false;  // Ceres: DENSE_SCHUR instead of SPARSE_SCHUR
  bool verbose = false;
};

struct IntegratedResult {
  std::string method;  // "svd" or "ceres"
  bool converged = false;
  int iterations = 0;
  int unknowns = 0;
  double cost = 0.0;  // total weighted cost (same definition as FastAdjustResult::cost)
  double rms_px = 0.0;
  double seconds = 0.0;
  std::string message;      // the solver's own summary line (of the last solve)
  int rig_tightenings = 0;  // re-solves with tighter held rig sigmas (Network.hpp)
  int redundancy = 0;       // of the solution (EoCovariance.hpp networkRedundancy)
  double sigma0 = 0.0;      // sqrt(cost / redundancy)
  std::string
      covariance_note;  // covarianceWarning() of the solution: why its EO sigmas are zero, if they are
};

// The report's warning when an EO covariance was refused with `status` (EoCovariance.hpp; its sigmas are
// then zero); empty for kOk.
std::string covarianceWarning(Status status);

// Both throw std::runtime_error on a network they cannot solve (no unknowns, non-finite values).
IntegratedResult adjustSvd(Network& net, const IntegratedOptions& options = {});
IntegratedResult adjustCeres(Network& net, const IntegratedOptions& options = {});

}  // namespace areomap::ground
