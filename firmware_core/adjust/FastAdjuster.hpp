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
//   kAlternation: the paper's method — alternate per-pair 12x12 solves (points fixed, or eliminated) and
//     per-point 3x3 solves. Plain alternation is a nonlinear block Gauss-Seidel iteration that stalls on a
//     panorama (shared/reference/fast-adjustment.md), so the sweep map is Anderson-accelerated over the
//     stacked EO vector in the tangent space (fixed-size history; the extrapolated EO is kept only if the
//     total weighted cost goes down, else the plain sweep is taken).
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
// Memory: the workspace lives in the adjuster object (~15 MiB at full capacity: allocate it once, e.g.
// static); adjust() makes no heap allocation, throws nothing, and every loop is bounded by a named constant.
#pragma once

#include <cstdint>

#include "firmware_core/adjust/Constraints.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/Status.hpp"

namespace areomap {

constexpr int32_t kMaxFastSweeps = 2000;          // one sweep = all pairs + all points; ~80 usually suffice
constexpr int32_t kMaxAndersonDepth = 12;         // history of the accelerated sweep map
constexpr int32_t kMaxRejectionRounds = 5;        // robust re-solves
constexpr int32_t kMaxStopWindow = 16;            // sweeps of the relative-cost stop window
constexpr int32_t kMaxEoUnknowns = 6 * kMaxImages;
constexpr int32_t kMinObservationsPerImage = 3;   // a camera needs at least 3 rays to be resected

constexpr int32_t kMaxPcgIterations = 200;      // conjugate-gradient steps per linearisation
// kSchurCholesky: 12x12 blocks of the RCS factor (diagonal + structural non-zeros below it, fill included).
// A two-tier ring of 64 pairs needs a few hundred; 2048 also holds 64 fully coupled pairs (64*65/2). The
// pool shares its memory with the alternation's per-point coupling blocks (same size, never both in use).
constexpr int32_t kMaxFactorBlocks = 2048;

// How the fast adjuster solves (all use only per-pair 12x12 and per-point 3x3 blocks and fixed memory; see the
// top of this file): kAlternation (the paper's, Anderson-accelerated), kSchurPcg (LM, RCS by block-Jacobi
// conjugate gradients), kSchurCholesky (LM, RCS by block-sparse Cholesky; the default).
enum class FastMethod : uint8_t { kAlternation = 0, kSchurPcg = 1, kSchurCholesky = 2 };
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
  int32_t max_sweeps = 1000;              // <= kMaxFastSweeps (LM methods: linearisations)
  double pcg_relative_tolerance = 1e-3;   // kSchurPcg: |residual| / |rhs| of the reduced system
  // true: each pair's 12x12 block is the REDUCED one (its points eliminated by their 3x3 blocks, the
  // other pairs fixed), solved pair after pair (block Gauss-Seidel on the reduced camera system), then the
  // points are back-substituted (3x3). false: the paper's plain alternation (pair with points fixed, then
  // points with EO fixed). Both use only 12x12 and 3x3 solves and fixed memory.
  bool reduced_pair_solves = true;
  bool anderson = true;
  int32_t anderson_depth = 10;            // <= kMaxAndersonDepth
  int32_t window = 5;                     // <= kMaxStopWindow
  double relative_cost_tolerance = 1e-9;
  double eo_step_tolerance_px = 1e-4;
  double nominal_range_m = 5.0;           // range of the pixel-equivalent measure
  bool robust = true;
  double reject_k = 5.0;
  double reject_floor_sigma = 4.5;        // never reject below 4.5 sigma (whitened norm, P ~ 4e-5)
  // Optional caller-owned trace of the final solve: total cost and largest EO step (px) after each sweep.
  double* cost_trace = nullptr;
  double* step_trace = nullptr;
  int32_t trace_capacity = 0;
};

struct FastAdjustResult {
  Status status = Status::kOk;
  StopRule stop_rule = StopRule::kNone;
  int32_t sweeps = 0;            // of the final solve
  int32_t sweeps_total = 0;      // over all rejection rounds
  int32_t rejection_rounds = 0;
  int32_t pcg_iterations = 0;        // kSchurPcg: conjugate-gradient steps over all linearisations
  int32_t factor_blocks = 0;         // kSchurCholesky: 12x12 blocks of the RCS factor (fill included)
  int32_t factorisations = 0;        // kSchurCholesky: RCS factorisations (accepted + rejected LM steps)
  bool cholesky_fallback = false;    // kSchurCholesky: the factor did not fit kMaxFactorBlocks; PCG was used
  int32_t anderson_accepted = 0;
  int32_t anderson_rejected = 0;
  int32_t rejected_observations = 0;  // rejected in this call (flags already set before are kept)
  int32_t unsolvable_points = 0;
  int32_t active_observations = 0;
  int32_t degenerate_image = -1;      // the image that made the network degenerate, if any
  int32_t redundancy = 0;
  double cost = 0.0;                  // total weighted cost (sum of whitened squares)
  double sigma0 = 0.0;                // a-posteriori sigma naught
  double rms_px = 0.0;                // RMS of the image residuals (per coordinate), pixels
  double last_step_px = 0.0;          // largest EO update of the last sweep, pixel equivalent
  ConstraintMisfit max_misfit;        // largest constraint misfits after the adjustment
  int32_t rig_tightenings = 0;        // re-solves with tighter held rig sigmas (Network.hpp)
  bool held_rig_met = true;           // every held constraint holds to kRigMisfitBound_m
};

// "Pixel equivalent" of an EO difference (one definition for the whole project): f x (rotation angle +
// centre difference / nominal range), i.e. the image displacement of a point at the nominal range.
double eoPixelEquivalent(double f_px, const Vec3& d_center_m, double angle_rad, double nominal_range_m);

class FastAdjuster {
 public:
  // Checks that every image has enough rays of solvable points and that they are not all on a line, and
  // marks points with fewer than 2 active rays unsolvable. kDegenerate names the image in bad_image.
  [[nodiscard]] Status checkNetwork(Network& net, int32_t& bad_image);

  // Adjusts the network in place from its current EO and points (a warm start when called again after
  // adding pairs). EO sigmas are written into each NetImage.
  [[nodiscard]] Status adjust(Network& net, const FastAdjustOptions& options, FastAdjustResult& result);

  // Total weighted cost and image RMS of the current state, no update.
  double evaluateCost(const Network& net, double* rms_px = nullptr, int32_t* active = nullptr) const;

 private:
  void buildImageIndex(const Network& net);
  [[nodiscard]] Status solve(Network& net, const FastAdjustOptions& options, FastAdjustResult& result);
  [[nodiscard]] Status pairStep(Network& net, bool keep_normals);
  [[nodiscard]] Status reducedSweep(Network& net);
  [[nodiscard]] Status solveLm(Network& net, const FastAdjustOptions& options, FastAdjustResult& result);
  void pcgStep(Network& net, const FastAdjustOptions& options, double damping, FastAdjustResult& result);
  void eliminatePoints(Network& net, double damping);
  void linearize(const Network& net);
  void pointBlocks(const Network& net, double damping);
  int32_t pairBlock(const Network& net, int32_t pair, Mat12& n, Vec12& b, bool couple);
  bool orderPairs(const Network& net);
  bool assembleAndFactor(const Network& net, double damping);
  void solveFactor(const Network& net);
  Eigen::Map<Mat12, Eigen::Aligned16> factorBlock(int32_t row, int32_t col) {
    return Eigen::Map<Mat12, Eigen::Aligned16>(shared_ + 144 * block_pos_[row][col]);
  }
  Eigen::Map<Mat12x3, Eigen::Aligned16> coupling(int32_t point) {
    return Eigen::Map<Mat12x3, Eigen::Aligned16>(shared_ + 36 * point);
  }
  Eigen::Map<const Mat12x3, Eigen::Aligned16> coupling(int32_t point) const {
    return Eigen::Map<const Mat12x3, Eigen::Aligned16>(shared_ + 36 * point);
  }
  void reducePairBlock(int32_t n_touched, Mat12& n, Vec12* b) const;
  void reducedProduct(const Network& net, const double* x, double* y) const;
  void pointStep(Network& net);
  int32_t rejectOutliers(Network& net, const FastAdjustOptions& options);
  void readTangent(const Network& net, double* x) const;
  void writeTangent(Network& net, const double* x) const;
  bool andersonCandidate(int32_t dim, const double* g, double* candidate);

  int32_t image_obs_start_[kMaxImages + 1] = {};
  int32_t image_obs_[kMaxObservations] = {};
  Mat12 pair_normal_[kMaxPairs];
  bool pair_normal_ok_[kMaxPairs] = {};

  double scale_[kMaxEoUnknowns] = {};  // tangent -> pixel-equivalent radians (Anderson inner product)
  double x_[kMaxEoUnknowns] = {};
  double g_[kMaxEoUnknowns] = {};
  double candidate_[kMaxEoUnknowns] = {};
  double hist_f_[kMaxAndersonDepth + 1][kMaxEoUnknowns] = {};
  double hist_g_[kMaxAndersonDepth + 1][kMaxEoUnknowns] = {};
  int32_t hist_count_ = 0;
  int32_t hist_head_ = 0;  // index of the newest entry
  int32_t depth_ = 0;

  double scratch_[2 * kMaxObservations] = {};

  // Reduced pair solves: per point its 3x3 inverse normal block, right-hand side and coupling to the pair
  // being solved; `mark_` holds the last pair that touched a point.
  Mat3 point_inverse_[kMaxTiePoints];
  Vec3 point_rhs_[kMaxTiePoints];
  // The alternation's coupling W (12x3) of the pair being solved to each of its points, OR (kSchurCholesky)
  // the pool of 12x12 factor blocks: one shared buffer, the two are never in use at the same time.
  static constexpr int32_t kSharedDoubles =
      36 * kMaxTiePoints > 144 * kMaxFactorBlocks ? 36 * kMaxTiePoints : 144 * kMaxFactorBlocks;
  alignas(64) double shared_[kSharedDoubles] = {};
  // kSchurCholesky: the pairs' elimination order (order_[k] = pair, position_[pair] = k), the factor's
  // pattern (block_pos_[row][col] = pool slot for row >= col in that order, -1 = structural zero; column k's
  // rows below the diagonal in col_rows_[col_start_[k] .. col_start_[k+1])), the pair graph used to find it,
  // and the RCS right-hand side / solution (12 per pair, in elimination order).
  int32_t order_[kMaxPairs] = {};
  int32_t position_[kMaxPairs] = {};
  int16_t block_pos_[kMaxPairs][kMaxPairs] = {};
  int32_t col_start_[kMaxPairs + 1] = {};
  int16_t col_rows_[kMaxFactorBlocks] = {};
  bool graph_[kMaxPairs][kMaxPairs] = {};
  int32_t factor_blocks_ = 0;
  double rcs_b_[12 * kMaxPairs] = {};
  bool point_eliminated_[kMaxTiePoints] = {};
  int32_t mark_[kMaxTiePoints] = {};
  int32_t touched_[kMaxTiePoints] = {};
  // Per observation, from the point pass of a reduced sweep (a pair's own observations do not change until
  // the pair is solved): whitened residual and Jacobians (~10 MiB at full capacity).
  Vec2 obs_residual_[kMaxObservations];
  Mat2x6 obs_d_image_[kMaxObservations];
  Mat2x3 obs_d_point_[kMaxObservations];
  bool obs_valid_[kMaxObservations] = {};
  // LM methods: pair blocks (12x12 with constraints and damping), their reduced inverses (preconditioner),
  // the conjugate-gradient vectors and the state saved for a rejected step.
  Mat12 pair_inverse_[kMaxPairs];
  double pcg_x_[kMaxEoUnknowns] = {};
  double pcg_r_[kMaxEoUnknowns] = {};
  double pcg_z_[kMaxEoUnknowns] = {};
  double pcg_p_[kMaxEoUnknowns] = {};
  double pcg_q_[kMaxEoUnknowns] = {};
  Vec3 saved_center_[kMaxImages];
  Mat3 saved_m_[kMaxImages];
  Vec3 saved_xyz_[kMaxTiePoints];
};

}  // namespace areomap
