// The traverse adjuster's solve (SitePoseAdjuster.hpp): one Levenberg-Marquardt solve over the reduced
// system of the free sites' poses (points eliminated, Huber weights when set), the robust rejection of
// the worst observation per point, each site's link, and the precision of the poses at the solution.
// No heap; every loop bounded.
#include "firmware_core/adjust/SitePoseAdjuster.hpp"

#include <algorithm>
#include <cmath>

namespace areomap {

namespace {

// Marquardt damping on diag(S), started small: the first steps from odometry are good Gauss-Newton steps,
// and the fast adjuster's 1e-4 only held them back (one more linearisation on the test traverses).
constexpr double kInitialDamping = 1e-8;
constexpr double kMaxDamping = 1e12;
constexpr double kMinDamping = 1e-12;
// Damping at or below which a step counts as a Gauss-Newton step for the stop rule.
constexpr double kGaussNewtonDamping = 1e-2;

}  // namespace

template <typename C>
void BasicSitePoseAdjuster<C>::weightRows(Vec2& error, Mat2x6& d_pose, Mat2x3& d_point) const {
  const double norm = error.norm();
  if (!(huber_ > 0.0) || !(norm > huber_)) return;
  // Huber: rho(s) = 2 c s - c^2 beyond c, i.e. the rows scaled by sqrt(c / s) (iteratively reweighted).
  const double w = std::sqrt(huber_ / norm);
  error *= w;
  d_pose *= w;
  d_point *= w;
}

template <typename C>
void BasicSitePoseAdjuster<C>::assemble(double damping) {
  system_.reset(site_count_ - first_free_);
  for (int32_t k = 1; k < site_count_; ++k) {
    if (!legActive(k)) continue;
    Vec6 e;
    Mat6 ja, jb;
    odometryRows(sites_[k - 1].pose, sites_[k].pose, sites_[k].leg, e, &ja, &jb);
    const int32_t ia = k - 1 - first_free_;
    const int32_t ib = k - first_free_;
    if (freeSite(k - 1)) {
      system_.add(ia, ia, ja.transpose() * ja);
      system_.rhs(ia).noalias() -= ja.transpose() * e;
    }
    if (freeSite(k)) {
      system_.add(ib, ib, jb.transpose() * jb);
      system_.rhs(ib).noalias() -= jb.transpose() * e;
    }
    if (freeSite(k - 1) && freeSite(k)) system_.add(ib, ia, jb.transpose() * ja);
  }
  for (int32_t p = 0; p < point_count_; ++p) {
    CrossSitePoint& pt = points_[p];
    point_eliminated_[p] = false;
    if (!inSolve(pt)) continue;
    Mat3 n = Mat3::Zero();
    Vec3 b = Vec3::Zero();
    int32_t slot_site[kMaxObsPerCrossSitePoint];
    Mat6x3 w[kMaxObsPerCrossSitePoint];
    int32_t slots = 0;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const CrossSiteObservation& o = observations_[pt.obs[k]];
      if (o.rejected) continue;
      const SiteCamera& c = cameras_[o.camera];
      Vec2 e;
      Mat2x6 jpose;
      Mat2x3 jpoint;
      if (!ok(observationRows(o, e, &jpose, &jpoint))) continue;
      weightRows(e, jpose, jpoint);
      n.noalias() += jpoint.transpose() * jpoint;
      b.noalias() -= jpoint.transpose() * e;
      if (!freeSite(c.site)) continue;
      int32_t slot = 0;
      while (slot < slots && slot_site[slot] != c.site) ++slot;
      if (slot == slots) {
        slot_site[slots] = c.site;
        w[slots].setZero();
        ++slots;
      }
      w[slot].noalias() += jpose.transpose() * jpoint;
      const int32_t is = c.site - first_free_;
      system_.add(is, is, jpose.transpose() * jpose);
      system_.rhs(is).noalias() -= jpose.transpose() * e;
    }
    n.diagonal() *= 1.0 + damping;
    const Eigen::LLT<Mat3> llt(n);
    if (llt.info() != Eigen::Success) continue;  // held where it is for this step
    const Mat3 n_inv = llt.solve(Mat3::Identity());
    if (!n_inv.allFinite()) continue;
    point_eliminated_[p] = true;
    point_inverse_[p] = n_inv;
    point_rhs_[p] = b;
    const Vec3 n_inv_b = n_inv * b;
    for (int32_t a = 0; a < slots; ++a) {
      const int32_t ia = slot_site[a] - first_free_;
      system_.rhs(ia).noalias() -= w[a] * n_inv_b;
      Mat6x3 wn;
      wn.noalias() = w[a] * n_inv;
      for (int32_t c = 0; c <= a; ++c) {
        const int32_t ic = slot_site[c] - first_free_;
        system_.add(ia, ic, -(wn * w[c].transpose()));
      }
    }
  }
}

template <typename C>
double BasicSitePoseAdjuster<C>::applyStep(const SitePoseOptions& options) {
  // Points first, from the rows at the state the system was assembled at: dx = N^-1 (b - W^T x).
  for (int32_t p = 0; p < point_count_; ++p) {
    point_step_[p].setZero();
    if (!point_eliminated_[p]) continue;
    const CrossSitePoint& pt = points_[p];
    Vec3 r = point_rhs_[p];
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const CrossSiteObservation& o = observations_[pt.obs[k]];
      const SiteCamera& c = cameras_[o.camera];
      if (o.rejected || !freeSite(c.site)) continue;
      Vec2 e;
      Mat2x6 jpose;
      Mat2x3 jpoint;
      if (!ok(observationRows(o, e, &jpose, &jpoint))) continue;
      weightRows(e, jpose, jpoint);
      Vec2 jx;
      jx.noalias() = jpose * site_step_[c.site - first_free_];
      r.noalias() -= jpoint.transpose() * jx;
    }
    point_step_[p].noalias() = point_inverse_[p] * r;
  }
  for (int32_t p = 0; p < point_count_; ++p) points_[p].xyz_m += point_step_[p];
  double step_m = 0.0;
  for (int32_t k = first_free_; k < site_count_; ++k) {
    const Vec6& d = site_step_[k - first_free_];
    step_m = std::max(step_m, d.head<3>().norm() + options.nominal_range_m * d.tail<3>().norm());
    applySiteUpdate(d, sites_[k].pose);
  }
  return step_m;
}

template <typename C>
Status BasicSitePoseAdjuster<C>::solve(const SitePoseOptions& options, SitePoseResult& result) {
  double current = cost();
  if (!std::isfinite(current)) return Status::kNotFinite;
  double damping = kInitialDamping;
  result.converged = false;
  result.iterations = 0;
  const int32_t n = site_count_ - first_free_;
  for (int32_t it = 0; it < options.max_iterations; ++it) {
    result.iterations = it + 1;
    ++result.iterations_total;
    assemble(damping);
    if (!system_.factor(damping)) {
      damping *= 10.0;
      if (damping > kMaxDamping) break;
      continue;
    }
    system_.solve(site_step_);
    for (int32_t k = 0; k < n; ++k) {
      if (!site_step_[k].allFinite()) return Status::kNotFinite;
    }
    for (int32_t k = 0; k < site_count_; ++k) saved_pose_[k] = sites_[k].pose;
    for (int32_t p = 0; p < point_count_; ++p) saved_xyz_[p] = points_[p].xyz_m;
    const double used_damping = damping;
    const double step_m = applyStep(options);
    const double next = cost();
    const bool small = step_m < options.step_tolerance_m && used_damping <= kGaussNewtonDamping;
    if (std::isfinite(next) && next < current) {
      const double decrease = current - next;
      current = next;
      damping = std::max(damping * 0.1, kMinDamping);
      if (small || (decrease <= options.relative_cost_tolerance * current &&
                    step_m < 100.0 * options.step_tolerance_m)) {
        result.converged = true;
        break;
      }
    } else {
      for (int32_t k = 0; k < site_count_; ++k) sites_[k].pose = saved_pose_[k];
      for (int32_t p = 0; p < point_count_; ++p) points_[p].xyz_m = saved_xyz_[p];
      if (small && std::isfinite(next) && next - current <= options.relative_cost_tolerance * current) {
        result.converged = true;  // a tiny exact step that does not lower the cost: the minimum, to rounding
        break;
      }
      damping *= 10.0;
      if (damping > kMaxDamping) break;
    }
  }
  return Status::kOk;
}

template <typename C>
void BasicSitePoseAdjuster<C>::readmitWindowObservations() {
  for (int32_t p = 0; p < point_count_; ++p) {
    const CrossSitePoint& pt = points_[p];
    bool seen_by_free = false;
    for (int32_t k = 0; k < pt.obs_count && !seen_by_free; ++k)
      seen_by_free = freeSite(cameras_[observations_[pt.obs[k]].camera].site);
    if (!seen_by_free) continue;
    for (int32_t k = 0; k < pt.obs_count; ++k) observations_[pt.obs[k]].rejected = false;
  }
}

template <typename C>
int32_t BasicSitePoseAdjuster<C>::rejectOutliers(const SitePoseOptions& options) {
  int32_t n = 0;
  for (int32_t o = 0; o < observation_count_; ++o) {
    if (!usable(observations_[o])) continue;
    Vec2 e;
    if (!ok(observationError(o, e))) continue;
    scratch_[n++] = std::fabs(e.x());
    scratch_[n++] = std::fabs(e.y());
  }
  if (n == 0) return 0;
  std::nth_element(scratch_, scratch_ + n / 2, scratch_ + n);
  const double threshold = std::max(options.reject_k * 1.4826 * scratch_[n / 2], options.reject_floor_sigma);
  int32_t rejected = 0;
  for (int32_t p = 0; p < point_count_; ++p) {
    const CrossSitePoint& pt = points_[p];
    if (!inSolve(pt)) continue;
    int32_t worst = -1;
    double worst_norm = threshold;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      if (observations_[pt.obs[k]].rejected) continue;
      Vec2 e;
      const double norm = ok(observationError(pt.obs[k], e)) ? e.norm() : 1e300;  // behind: an outlier too
      if (norm > worst_norm) {
        worst_norm = norm;
        worst = pt.obs[k];
      }
    }
    if (worst >= 0) {
      observations_[worst].rejected = true;
      ++rejected;
    }
  }
  return rejected;
}

template <typename C>
void BasicSitePoseAdjuster<C>::linkStatus(SitePoseResult& result) {
  for (int32_t k = 0; k < site_count_; ++k) sites_[k].tie_observations = 0;
  for (int32_t p = 0; p < point_count_; ++p) {
    const CrossSitePoint& pt = points_[p];
    if (!inSolve(pt)) continue;
    int32_t first_site = -1;
    bool cross = false;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const CrossSiteObservation& o = observations_[pt.obs[k]];
      if (o.rejected) continue;
      const int32_t s = cameras_[o.camera].site;
      if (first_site < 0) first_site = s;
      cross = cross || s != first_site;
    }
    if (!cross) continue;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const CrossSiteObservation& o = observations_[pt.obs[k]];
      if (!o.rejected) ++sites_[cameras_[o.camera].site].tie_observations;
    }
  }
  result.no_overlap_sites = 0;
  for (int32_t k = 0; k < site_count_; ++k) {
    SiteState& s = sites_[k];
    if (!freeSite(k)) {
      s.link = SiteLink::kHeld;
    } else if (s.tie_observations > 0) {
      s.link = SiteLink::kTied;
    } else {
      s.link = SiteLink::kNoOverlap;
      ++result.no_overlap_sites;
    }
  }
}

template <typename C>
Status BasicSitePoseAdjuster<C>::precision(SitePoseResult& result, bool covariance) {
  result.cost = cost(&result.rms_px, &result.active_observations);
  result.solvable_points = 0;
  result.unsolvable_points = 0;
  result.points_outside_window = 0;
  for (int32_t p = 0; p < point_count_; ++p) {
    if (inSolve(points_[p])) {
      ++result.solvable_points;
    } else if (points_[p].solvable) {
      ++result.points_outside_window;
    } else {
      ++result.unsolvable_points;
    }
  }
  int32_t legs = 0;
  for (int32_t k = 1; k < site_count_; ++k) legs += legActive(k) ? 1 : 0;
  result.redundancy =
      2 * result.active_observations + 6 * legs - 6 * result.free_sites - 3 * result.solvable_points;
  result.sigma0 = result.redundancy > 0 ? std::sqrt(result.cost / result.redundancy) : 0.0;
  for (int32_t k = 0; k < site_count_; ++k) {
    sites_[k].covariance.setZero();
    sites_[k].sigma.setZero();
  }
  if (!covariance || result.free_sites == 0) return Status::kOk;
  assemble(0.0);
  if (!system_.factor(0.0)) {
    result.covariance_status = Status::kDegenerate;
    return Status::kOk;
  }
  const double scale = std::max(1.0, result.sigma0);
  for (int32_t k = first_free_; k < site_count_; ++k) {
    const Mat6 c = system_.inverseDiagonalBlock(k - first_free_) * (scale * scale);
    if (!c.allFinite()) {
      result.covariance_status = Status::kNotFinite;
      return Status::kOk;
    }
    sites_[k].covariance = c;
    sites_[k].sigma = c.diagonal().cwiseMax(0.0).cwiseSqrt();
  }
  return Status::kOk;
}

template class BasicSitePoseAdjuster<TraverseCapacity<kMaxSites>>;
template class BasicSitePoseAdjuster<TraverseCapacity<kMaxGroundSites>>;

}  // namespace areomap
