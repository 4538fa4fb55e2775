#include "firmware_core/adjust/FastAdjustOptions.hpp"

#include <algorithm>
#include <cmath>

namespace areomap {

const char* stopRuleName(StopRule rule) {
  switch (rule) {
    case StopRule::kCostAndStep:
      return "cost_and_step";
    case StopRule::kMaxSweeps:
      return "max_sweeps";
    case StopRule::kNoDecrease:
      return "no_decrease";
    default:
      return "none";
  }
}

const char* fastMethodName(FastMethod method) {
  switch (method) {
    case FastMethod::kSchurPcg:
      return "schur_pcg";
    case FastMethod::kSchurCholesky:
      return "schur_cholesky";
    case FastMethod::kPaperAlternation:
      return "paper_alternation";
    default:
      return "gauss_seidel_anderson";
  }
}

double eoPixelEquivalent(double f_px, const Vec3& d_centre_m, double angle_rad, double nominal_range_m) {
  return f_px * (std::fabs(angle_rad) + d_centre_m.norm() / nominal_range_m);
}

int32_t boundedSweeps(const FastAdjustOptions& options) {
  return std::min(std::max(options.max_sweeps, 1), kMaxFastSweeps);
}

int32_t boundedWindow(const FastAdjustOptions& options) {
  return std::min(std::max(options.window, 1), kMaxStopWindow);
}

void traceSweep(const FastAdjustOptions& options, int32_t sweep, double cost, double step_px) {
  if (sweep >= options.trace_capacity) return;
  if (options.cost_trace != nullptr) options.cost_trace[sweep] = cost;
  if (options.step_trace != nullptr) options.step_trace[sweep] = step_px;
}

}  // namespace areomap
