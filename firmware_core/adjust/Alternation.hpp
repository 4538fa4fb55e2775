// kGaussSeidelAnderson and kPaperAlternation (FastAdjuster.hpp): sweeps of per-pair 12x12 solves and
// per-point 3x3 solves (Di, Xu, Li §3.3) until the stop rule of FastAdjuster.hpp holds. A sweep is one of
//   reduced (FastAdjustOptions::reduced_pair_solves, the default): pair after pair, the pair's REDUCED block
//     (its points eliminated by their 3x3 blocks, the other pairs fixed), i.e. block Gauss-Seidel on the
//     reduced camera system, then the points back-substituted;
//   plain: every pair with its points fixed, then (as after every sweep) every point with the EO fixed.
// Plain alternation is a nonlinear block Gauss-Seidel iteration that stalls on a panorama
// (shared/reference/fast-adjustment.md), so the sweep map is Anderson-accelerated over the stacked EO
// vector in the tangent space (AndersonAccelerator; the extrapolated EO is kept only if the total weighted
// cost goes down, else the plain sweep is taken). Another kind of sweep is one more case of sweep().
#pragma once

#include <cstdint>

#include "firmware_core/adjust/AdjustWorkspace.hpp"
#include "firmware_core/adjust/FastAdjustOptions.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/base/Status.hpp"

namespace areomap {

// Anderson acceleration of a fixed-point map x -> G(x) over the EO tangent vector (6 per image): a history
// of the last depth + 1 pairs (F = G(x) - x, G(x)); the candidate is G(x) minus the combination of the
// G differences whose F differences best cancel the newest F, in the pixel-equivalent inner product (centre
// components scaled by f / nominal range, rotations by f, so that every unknown counts in pixels).
class AndersonAccelerator {
 public:
  // An empty history of depth `depth` (clamped to 1..kMaxAndersonDepth) with the scales of `net`'s images.
  void reset(const Network& net, double nominal_range_m, int32_t depth);
  // Appends (g - x, g), dropping the oldest entry when the history is full.
  void push(int32_t dim, const double* x, const double* g);
  // The extrapolated point from the newest map value `g`; false with fewer than two entries or a singular
  // (regularised) least-squares system.
  bool candidate(int32_t dim, const double* g, double* candidate) const;

 private:
  double scale_[kMaxEoUnknowns] = {};  // tangent -> pixel-equivalent radians (the inner product)
  double hist_f_[kMaxAndersonDepth + 1][kMaxEoUnknowns] = {};
  double hist_g_[kMaxAndersonDepth + 1][kMaxEoUnknowns] = {};
  int32_t count_ = 0;
  int32_t depth_ = 0;
};

class Alternation {
 public:
  // Sweeps from the network's current state until the stop rule or the sweep bound; counts into `result`
  // (sweeps, sweeps_total, anderson_accepted / rejected, last_step_px, stop_rule) and the caller's trace.
  [[nodiscard]] Status solve(Network& net, AdjustWorkspace& ws, const FastAdjustOptions& options,
                             FastAdjustResult& result);

 private:
  // One pair pass of the kind `options` asks for (the point pass follows in solve()).
  [[nodiscard]] Status sweep(Network& net, AdjustWorkspace& ws, const FastAdjustOptions& options);
  [[nodiscard]] Status reducedSweep(Network& net, AdjustWorkspace& ws);

  AndersonAccelerator anderson_;
  // The EO tangent (against the a-priori EO) before the sweep, after it, and the accelerated candidate.
  double x_[kMaxEoUnknowns] = {};
  double g_[kMaxEoUnknowns] = {};
  double candidate_[kMaxEoUnknowns] = {};
};

}  // namespace areomap
