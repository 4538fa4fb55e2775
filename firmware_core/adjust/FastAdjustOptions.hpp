// What the fast constrained bundle adjustment (FastAdjuster.hpp) is asked to do and what it reports: the
// method, its bounds and tolerances, and the result figures. Shared by the front (FastAdjuster) and the
// solvers (Alternation, PcgSolver, BlockCholesky), which is why it is a header of its own.
#pragma once

#include <cstdint>

#include "firmware_core/adjust/Constraints.hpp"
#include "firmware_core/adjust/EoCovariance.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/Status.hpp"

namespace areomap {

constexpr int32_t kMaxFastSweeps = 2000;         // one sweep = all pairs + all points; ~80 usually suffice
constexpr int32_t kMaxAndersonDepth = 12;        // history of the accelerated sweep map
constexpr int32_t kMaxRejectionRounds = 5;       // robust re-solves
constexpr int32_t kMaxStopWindow = 16;           // sweeps of the relative-cost stop window
constexpr int32_t kMinObservationsPerImage = 3;  // a camera needs at least 3 rays to be resected

// How the fast adjuster solves (all use only per-pair 12x12 and per-point 3x3 blocks and fixed memory; see
// the top of FastAdjuster.hpp): kSchurCholesky (LM, RCS by block-sparse Cholesky; the default), kSchurPcg
// (LM, RCS by block-Jacobi conjugate gradients), kGaussSeidelAnderson (block Gauss-Seidel on the RCS, pair
// after pair with its points eliminated, Anderson-accelerated), kPaperAlternation (the paper's §3.3 step as
// written: every pair's EO with the points fixed, then every point with the EO fixed, nothing more).
enum class FastMethod : uint8_t {
  kGaussSeidelAnderson = 0,
  kSchurPcg = 1,
  kSchurCholesky = 2,
  kPaperAlternation = 3
};
const char* fastMethodName(FastMethod method);

enum class StopRule : uint8_t {
  kNone = 0,
  kCostAndStep,  // relative cost decrease over the window and the largest EO step both below tolerance
  kMaxSweeps,    // the sweep bound fired
  kNoDecrease,   // LM methods: no damped step lowers the cost any more (the minimum to machine precision)
};
const char* stopRuleName(StopRule rule);

struct FastAdjustOptions {
  FastMethod method = FastMethod::kSchurCholesky;
  int32_t max_sweeps = 1000;             // <= kMaxFastSweeps (LM methods: linearisations)
  double pcg_relative_tolerance = 1e-3;  // kSchurPcg: |residual| / |rhs| of the reduced system
  // kGaussSeidelAnderson only (kPaperAlternation sets both false). reduced_pair_solves true: each pair's
  // 12x12 block is the REDUCED one (its points eliminated by their 3x3 blocks, the other pairs fixed),
  // solved pair after pair, then the points are back-substituted (3x3); false: the pair with its points
  // fixed, then the points with the EO fixed. anderson: the sweep map accelerated (Alternation.hpp).
  bool reduced_pair_solves = true;
  bool anderson = true;
  int32_t anderson_depth = 10;  // <= kMaxAndersonDepth
  int32_t window = 5;           // <= kMaxStopWindow
  double relative_cost_tolerance = 1e-9;
  double eo_step_tolerance_px = 1e-4;
  double nominal_range_m = 5.0;  // range of the pixel-equivalent measure
  bool robust = true;
  double reject_k = 5.0;
  double reject_floor_sigma = 4.5;  // never reject below 4.5 sigma (whitened norm, P ~ 4e-5)
  // The EO covariance at the end (EoCovariance.hpp); off, the sigmas are left as they were (a benchmark
  // timing the solve alone).
  bool eo_covariance = true;
  // Optional caller-owned trace of the final solve: total cost and largest EO step (px) after each sweep.
  double* cost_trace = nullptr;
  double* step_trace = nullptr;
  int32_t trace_capacity = 0;
};

struct FastAdjustResult {
  Status status = Status::kOk;
  StopRule stop_rule = StopRule::kNone;
  int32_t sweeps = 0;        // of the final solve
  int32_t sweeps_total = 0;  // over all rejection rounds
  int32_t rejection_rounds = 0;
  int32_t pcg_iterations = 0;      // kSchurPcg: conjugate-gradient steps over all linearisations
  int32_t factor_blocks = 0;       // kSchurCholesky: 12x12 blocks of the RCS factor (fill included)
  int32_t factorisations = 0;      // kSchurCholesky: RCS factorisations (accepted + rejected LM steps)
  bool cholesky_fallback = false;  // kSchurCholesky: the factor did not fit kMaxFactorBlocks; PCG was used
  int32_t anderson_accepted = 0;
  int32_t anderson_rejected = 0;
  int32_t rejected_observations = 0;  // rejected in this call (flags already set before are kept)
  int32_t unsolvable_points = 0;
  int32_t active_observations = 0;
  int32_t degenerate_image = -1;  // the image that made the network degenerate, if any
  int32_t redundancy = 0;
  double cost = 0.0;            // total weighted cost (sum of whitened squares)
  double sigma0 = 0.0;          // a-posteriori sigma naught
  double rms_px = 0.0;          // RMS of the image residuals (per coordinate), pixels
  double last_step_px = 0.0;    // largest EO update of the last sweep, pixel equivalent
  ConstraintMisfit max_misfit;  // largest constraint misfits after the adjustment
  int32_t rig_tightenings = 0;  // re-solves with tighter held rig sigmas (Network.hpp)
  bool held_rig_met = true;     // every held constraint holds to kRigMisfitBound_m
  // Which solver gave the EO covariance's columns (EoCovariance.hpp); kNone when it was not computed or
  // failed, and then covariance_status says why (kDegenerate: S is singular, the network not rigid) and
  // every sigma is zero.
  CovarianceSolver covariance_solver = CovarianceSolver::kNone;
  Status covariance_status = Status::kOk;
};

// "Pixel equivalent" of an EO difference (one definition for the whole project): f x (rotation angle +
// centre difference / nominal range), i.e. the image displacement of a point at the nominal range.
double eoPixelEquivalent(double f_px, const Vec3& d_centre_m, double angle_rad, double nominal_range_m);

// The sweep bound and the stop window of `options`, clamped to their named maxima.
int32_t boundedSweeps(const FastAdjustOptions& options);
int32_t boundedWindow(const FastAdjustOptions& options);

// Stores the cost and the largest EO step of sweep `sweep` in the caller's trace, where it has room.
void traceSweep(const FastAdjustOptions& options, int32_t sweep, double cost, double step_px);

}  // namespace areomap
