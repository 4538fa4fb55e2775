#include "firmware_core/adjust/FastAdjuster.hpp"

#include <algorithm>
#include <cmath>

#include "firmware_core/adjust/ReducedCameraSystem.hpp"

namespace areomap {

// The adjuster's workspace and the network it works on are static objects of the rover; together they must
// leave most of the 64 MiB budget to the matcher and the DEM.
static_assert(sizeof(FastAdjuster) + sizeof(Network) < kStaticMemoryBudgetBytes / 2,
              "adjustment workspace + network exceed half of the rover's static memory budget");

Status FastAdjuster::checkNetwork(Network& net, int32_t& bad_image) {
  bad_image = -1;
  // Points: at least two active rays.
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    NetPoint& pt = net.point(p);
    int32_t active = 0;
    for (int32_t k = 0; k < pt.obs_count; ++k) active += net.observation(pt.obs[k]).rejected ? 0 : 1;
    if (active < 2) pt.solvable = false;
    if (!pt.xyz_m.allFinite()) pt.solvable = false;
  }
  ws_.buildImageIndex(net);
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    int32_t n = 0;
    Vec3 mean = Vec3::Zero();
    for (int32_t k = ws_.image_obs_start[i]; k < ws_.image_obs_start[i + 1]; ++k) {
      const NetObservation& o = net.observation(ws_.image_obs[k]);
      if (!usableObservation(net, o)) continue;
      mean += net.point(o.point).xyz_m;
      ++n;
    }
    if (n < kMinObservationsPerImage) {
      bad_image = i;
      return Status::kDegenerate;
    }
    mean /= static_cast<double>(n);
    Mat3 cov = Mat3::Zero();
    for (int32_t k = ws_.image_obs_start[i]; k < ws_.image_obs_start[i + 1]; ++k) {
      const NetObservation& o = net.observation(ws_.image_obs[k]);
      if (!usableObservation(net, o)) continue;
      const Vec3 d = net.point(o.point).xyz_m - mean;
      cov.noalias() += d * d.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Mat3> eig(cov, Eigen::EigenvaluesOnly);
    // All points on one line: the middle eigenvalue vanishes (1e-10 relative ~ 10 um spread over 1 m).
    if (!(eig.eigenvalues()(1) > 1e-10 * eig.eigenvalues()(2))) {
      bad_image = i;
      return Status::kDegenerate;
    }
  }
  return Status::kOk;
}

double FastAdjuster::evaluateCost(const Network& net, double* rms_px, int32_t* active) const {
  return weightedCost(net, rms_px, active);
}

void FastAdjuster::saveState(const Network& net) {
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    saved_centre_[i] = net.image(i).centre_m;
    saved_m_[i] = net.image(i).m;
  }
  for (int32_t p = 0; p < net.pointCount(); ++p) saved_xyz_[p] = net.point(p).xyz_m;
}

void FastAdjuster::restoreState(Network& net) const {
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    net.image(i).centre_m = saved_centre_[i];
    net.image(i).m = saved_m_[i];
  }
  for (int32_t p = 0; p < net.pointCount(); ++p) net.point(p).xyz_m = saved_xyz_[p];
}

double FastAdjuster::applyStep(Network& net, const FastAdjustOptions& options) {
  double step_px = 0.0;
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    NetImage& im = net.image(i);
    const Eigen::Map<const Vec6> d(ws_.step + 6 * i);
    step_px = std::max(
        step_px, eoPixelEquivalent(im.io.f_px, d.head<3>(), d.tail<3>().norm(), options.nominal_range_m));
    applyCameraUpdate(d, im.centre_m, im.m);
  }
  backSubstitutePoints(net, ws_, ws_.step);
  return step_px;
}

Status FastAdjuster::solveLm(Network& net, const FastAdjustOptions& options, FastAdjustResult& result) {
  bool direct = options.method == FastMethod::kSchurCholesky;
  if (direct && !cholesky_.order(net)) {
    direct = false;
    result.cholesky_fallback = true;
  }
  result.factor_blocks = direct ? cholesky_.factorBlocks() : 0;
  const int32_t max_iterations = boundedSweeps(options);
  // The exact (direct) step converges quadratically: one accepted step is the window.
  const int32_t window = direct ? 1 : boundedWindow(options);
  double cost_window[kMaxStopWindow + 1] = {};
  double cost = evaluateCost(net);
  if (!std::isfinite(cost)) return Status::kNotFinite;
  double damping = 1e-4;
  constexpr double kMaxDamping = 1e12;
  constexpr double kMinDamping = 1e-12;
  int32_t accepted = 0;
  bool stale = true;  // the observation rows do not belong to the current state
  result.stop_rule = StopRule::kMaxSweeps;
  for (int32_t it = 0; it < max_iterations; ++it) {
    result.sweeps = it + 1;
    ++result.sweeps_total;
    if (stale) {
      linearize(net, ws_);
      stale = false;
    }
    if (direct) {
      ++result.factorisations;
      if (!cholesky_.assembleAndFactor(net, ws_, damping)) {
        damping *= 10.0;  // not positive definite at this damping
        if (damping > kMaxDamping) {
          result.stop_rule = StopRule::kNoDecrease;
          break;
        }
        continue;
      }
      cholesky_.solve(net, ws_);
    } else {
      pcg_.solve(net, ws_, options.pcg_relative_tolerance, damping, result.pcg_iterations);
    }
    // Save, apply the step (cameras, then back-substituted points), and keep it only if the cost drops.
    saveState(net);
    const double step_px = applyStep(net, options);
    const double new_cost = evaluateCost(net);
    if (std::isfinite(new_cost) && new_cost < cost) {
      for (int32_t w = window; w > 0; --w) cost_window[w] = cost_window[w - 1];
      cost_window[0] = cost;
      cost = new_cost;
      ++accepted;
      stale = true;
      damping = std::max(damping * 0.1, kMinDamping);
      result.last_step_px = step_px;
      traceSweep(options, it, cost, step_px);
      const double window_decrease = cost_window[window - 1] - cost;  // accepted steps only lower the cost
      if (accepted >= window && window_decrease <= options.relative_cost_tolerance * cost &&
          step_px < options.eo_step_tolerance_px) {
        result.stop_rule = StopRule::kCostAndStep;
        break;
      }
    } else {
      restoreState(net);
      // A tiny exact step that does not lower the cost: the minimum, to rounding.
      if (direct && accepted > 0 && step_px < options.eo_step_tolerance_px && std::isfinite(new_cost) &&
          new_cost - cost <= options.relative_cost_tolerance * cost) {
        result.stop_rule = StopRule::kCostAndStep;
        break;
      }
      damping *= 10.0;
      if (damping > kMaxDamping) {
        result.stop_rule = StopRule::kNoDecrease;
        break;
      }
    }
  }
  return Status::kOk;
}

Status FastAdjuster::solve(Network& net, const FastAdjustOptions& options, FastAdjustResult& result) {
  if (options.method == FastMethod::kGaussSeidelAnderson)
    return alternation_.solve(net, ws_, options, result);
  if (options.method == FastMethod::kPaperAlternation) {
    FastAdjustOptions paper = options;
    paper.reduced_pair_solves = false;
    paper.anderson = false;
    return alternation_.solve(net, ws_, paper, result);
  }
  return solveLm(net, options, result);
}

int32_t FastAdjuster::rejectOutliers(Network& net, const FastAdjustOptions& options) {
  double* abs_residual = ws_.scratch;
  int32_t n = 0;
  for (int32_t k = 0; k < net.observationCount(); ++k) {
    const NetObservation& o = net.observation(k);
    if (!usableObservation(net, o)) continue;
    Vec2 r;
    if (!ok(currentResidual(net, o, r))) continue;
    abs_residual[n++] = std::fabs(r.x());
    abs_residual[n++] = std::fabs(r.y());
  }
  if (n == 0) return 0;
  std::nth_element(abs_residual, abs_residual + n / 2, abs_residual + n);
  const double robust_sigma = 1.4826 * abs_residual[n / 2];
  const double threshold = std::max(options.reject_k * robust_sigma, options.reject_floor_sigma);
  int32_t rejected = 0;
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    NetPoint& pt = net.point(p);
    if (!pt.solvable) continue;
    int32_t worst = -1;
    double worst_norm = threshold;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const NetObservation& o = net.observation(pt.obs[k]);
      if (o.rejected) continue;
      Vec2 r;
      const Status s = currentResidual(net, o, r);
      const double norm = ok(s) ? r.norm() : 1e300;  // a ray behind its camera is an outlier too
      if (norm > worst_norm) {
        worst_norm = norm;
        worst = pt.obs[k];
      }
    }
    if (worst >= 0) {
      net.observation(worst).rejected = true;
      ++rejected;
      if (!ok(net.triangulate(p))) pt.solvable = false;
    }
  }
  return rejected;
}

Status FastAdjuster::precision(Network& net, FastAdjustResult& result, bool eo_covariance) {
  result.cost = evaluateCost(net, &result.rms_px, &result.active_observations);
  result.max_misfit = networkMisfit(net);
  result.held_rig_met = heldConstraintsMet(net.rig, result.max_misfit);
  for (int32_t p = 0; p < net.pointCount(); ++p) result.unsolvable_points += net.point(p).solvable ? 0 : 1;
  result.redundancy = networkRedundancy(net, result.active_observations);
  result.sigma0 = result.redundancy > 0 ? std::sqrt(result.cost / result.redundancy) : 0.0;
  if (!eo_covariance) return Status::kOk;
  // A network the constraints do not make rigid (e.g. both switched off: scale and translation free) has a
  // singular S: the adjustment stands, its sigmas stay zero and the result says why.
  result.covariance_status =
      covariance_.compute(net, ws_, cholesky_, pcg_, result.sigma0, result.covariance_solver,
                          CovarianceSolver::kCholesky, covariance_sink_);
  if (!ok(result.covariance_status)) {
    result.covariance_solver = CovarianceSolver::kNone;
    for (int32_t i = 0; i < net.imageCount(); ++i) net.image(i).sigma.setZero();
    for (int32_t p = 0; p < net.pairCount(); ++p) net.pair(p).covariance.setZero();
  }
  return Status::kOk;
}

Status FastAdjuster::precisionOf(Network& net, FastAdjustResult& result) {
  result = FastAdjustResult{};
  const Status s = checkNetwork(net, result.degenerate_image);
  result.status = ok(s) ? precision(net, result, true) : s;
  return result.status;
}

Status FastAdjuster::adjust(Network& net, const FastAdjustOptions& options, FastAdjustResult& result) {
  result = FastAdjustResult{};
  if (net.imageCount() == 0) {
    result.status = Status::kMissingField;
    return result.status;
  }
  for (int32_t round = 0; round <= kMaxRejectionRounds; ++round) {
    Status s = checkNetwork(net, result.degenerate_image);
    if (ok(s)) s = solve(net, options, result);
    if (!ok(s)) {
      result.status = s;
      return s;
    }
    if (!options.robust || round == kMaxRejectionRounds) break;
    const int32_t rejected = rejectOutliers(net, options);
    if (rejected == 0) break;
    result.rejected_observations += rejected;
    ++result.rejection_rounds;
  }
  // Held rig sigmas (Network.hpp): solved again, warm, with a tighter sigma while a held constraint's misfit
  // exceeds half its bound.
  for (int32_t t = 0; t < kMaxRigTightenings && tightenHeldSigmas(net.rig, networkMisfit(net)); ++t) {
    ++result.rig_tightenings;
    const Status s = solve(net, options, result);
    if (!ok(s)) {
      result.status = s;
      return s;
    }
  }
  result.status = precision(net, result, options.eo_covariance);
  return result.status;
}

}  // namespace areomap
