#include "ground/traverse/PoseHypotheses.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "firmware_core/base/Angles.hpp"
#include "ground/cli/Parallel.hpp"
#include "ground/traverse/DemCost.hpp"

namespace areomap::traverse {

namespace {

// The most of B's cells the grid's costs are taken on: its cost is samples times poses (a 2 m, 6 deg
// window has 4851 poses).
constexpr int kMaxHypothesisSamples = 8000;

}  // namespace

PoseHypotheses demPoseHypotheses(const SiteProducts& a, const SiteProducts& b,
                                 const DemRegistration& registration, const RegistrationParams& params,
                                 double sigmas) {
  PoseHypotheses out;
  if (registration.status == RegistrationStatus::kNoOverlap) return out;
  // The registration's coarse grid about the a-priori pose, costed on the full DEMs with B's cells one step
  // apart (the cost's resolution that of the poses').
  const double step_m = coarseStepM(params), step_rad = coarseStepRad(params);
  // At most kMaxHypothesisSamples of them, spread wider where B's DEM has more: the effective count n / D
  // that bounds V0's error changes little with the spacing while it is below the DEM errors' correlation
  // length (D falls as the spacing grows).
  RegistrationParams at_step = params;
  at_step.sample_spacing_m = step_m;
  std::vector<demcost::Sample> samples = demcost::samplesOf(b, b.dem, step_m, params);
  if (samples.size() > static_cast<std::size_t>(kMaxHypothesisSamples)) {
    at_step.sample_spacing_m =
        step_m * std::sqrt(static_cast<double>(samples.size()) / kMaxHypothesisSamples);
    samples = demcost::samplesOf(b, b.dem, at_step.sample_spacing_m, params);
  }
  const int min_samples = demcost::minSamples(a, b, at_step);
  const int nxy = static_cast<int>(std::lround(params.search_m / step_m));
  const int nh = static_cast<int>(std::lround(params.search_deg * kDegToRad / step_rad));
  const int sx = 2 * nxy + 1, sh = 2 * nh + 1;
  // The relative tilt of the two frames is the registration's where it registered (the grid's levelled
  // search does not see it).
  const bool registered = registration.status == RegistrationStatus::kOk;
  RelativePose centre = registration.apriori;
  Eigen::Matrix2d tilt_cov = Eigen::Matrix2d::Identity() * params.tilt_sigma_rad * params.tilt_sigma_rad;
  if (registered) {
    centre.tilt_rad = registration.a_from_b.tilt_rad;
    tilt_cov = registration.covariance.bottomRightCorner<2, 2>();
  }
  std::vector<PoseHypothesis> grid(static_cast<std::size_t>(sx) * sx * sh);
  std::vector<int> counts(grid.size(), 0);
  cli::parallelFor(grid.size(), 0, [&](std::size_t n) {
    const int k = static_cast<int>(n / (static_cast<std::size_t>(sx) * sx));
    const int j = static_cast<int>(n / sx % sx), i = static_cast<int>(n % sx);
    RelativePose pose = shiftedPose(centre, (i - nxy) * step_m, (j - nxy) * step_m, (k - nh) * step_rad);
    const demcost::Moments m = demcost::moments(a, a.dem, samples, pose, params);
    PoseHypothesis& h = grid[n];
    h.variance_m2 = std::numeric_limits<double>::infinity();
    if (m.n < min_samples) return;
    pose.translation_m.z() -= m.mean();  // d = e_a + z: moving B down by d zeroes the mean
    h.a_from_b = pose;
    h.variance_m2 = m.variance();
    counts[n] = m.n;
  });
  // V0: the least variance of the grid and of the registered pose.
  RelativePose best_pose;
  double v0 = std::numeric_limits<double>::infinity();
  int n0 = 0;
  for (std::size_t n = 0; n < grid.size(); ++n) {
    if (grid[n].variance_m2 < v0) {
      v0 = grid[n].variance_m2;
      n0 = counts[n];
      best_pose = grid[n].a_from_b;
    }
  }
  if (registered) {
    const demcost::Moments m = demcost::moments(a, a.dem, samples, registration.a_from_b, params);
    if (m.n >= min_samples && m.variance() < v0) {
      v0 = m.variance();
      n0 = m.n;
      best_pose = registration.a_from_b;
    }
  }
  if (!std::isfinite(v0) || n0 == 0) return out;
  out.best_variance_m2 = v0;
  out.samples = n0;
  out.design_effect = demcost::designEffect(a, samples, best_pose, at_step, std::sqrt(v0));
  out.bound_m2 = v0 * (1.0 + sigmas * std::sqrt(2.0 * out.design_effect / n0));
  std::vector<PoseHypothesis> plausible;
  for (PoseHypothesis& h : grid) {
    if (!(h.variance_m2 <= out.bound_m2)) continue;
    const double half_m = 0.5 * step_m, half_rad = 0.5 * step_rad;
    h.covariance.diagonal().head<4>() << half_m * half_m, half_m * half_m, h.variance_m2, half_rad * half_rad;
    h.covariance.bottomRightCorner<2, 2>() = tilt_cov;
    plausible.push_back(h);
  }
  // Best-fitting first; equal variances in the grid's order.
  std::stable_sort(plausible.begin(), plausible.end(), [](const PoseHypothesis& l, const PoseHypothesis& r) {
    return l.variance_m2 < r.variance_m2;
  });
  out.plausible = static_cast<int>(plausible.size());
  if (plausible.size() > static_cast<std::size_t>(kMaxPoseHypotheses)) plausible.resize(kMaxPoseHypotheses);
  out.poses = std::move(plausible);
  char buffer[320];
  std::snprintf(
      buffer, sizeof buffer,
      "%d poses of the %.1f m, %.1f deg window fit the DEMs within %.1f cm RMS of their best %.1f cm "
      "(%g sigmas of its sampling error: %d samples, design effect %.1f)",
      out.plausible, params.search_m, params.search_deg, 100.0 * std::sqrt(out.bound_m2),
      100.0 * std::sqrt(v0), sigmas, n0, out.design_effect);
  out.summary = buffer;
  return out;
}

}  // namespace areomap::traverse
