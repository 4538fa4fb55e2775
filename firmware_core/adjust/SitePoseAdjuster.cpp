#include "firmware_core/adjust/SitePoseAdjuster.hpp"

#include <algorithm>
#include <cmath>

#include "firmware_core/adjust/FastAdjustOptions.hpp"  // kMaxRejectionRounds, shared with the fast adjuster
#include "firmware_core/adjust/Network.hpp"            // rayOfIdealPixel
#include "firmware_core/camera/RayIntersection.hpp"

namespace areomap {

// The traverse adjuster is a rover-side static object beside the fast adjuster and its network.
static_assert(sizeof(SitePoseAdjuster) < kStaticMemoryBudgetBytes / 16,
              "the traverse adjuster must stay a small part of the rover's static memory budget");

namespace {

// An observation whose point lies behind its camera is charged far above any real residual, so that an LM
// step that puts a point behind a camera is rejected.
constexpr double kBehindCameraCost = 1e10;
// Marquardt damping on diag(S), started small: the first steps from odometry are good Gauss-Newton steps,
// and the fast adjuster's 1e-4 only held them back (one more linearisation on the test traverses).
constexpr double kInitialDamping = 1e-8;
constexpr double kMaxDamping = 1e12;
constexpr double kMinDamping = 1e-12;
// Damping at or below which a step counts as a Gauss-Newton step for the stop rule.
constexpr double kGaussNewtonDamping = 1e-2;
// The Huber solve before the rejection rounds: bounded, and stopped at a millimetre step.
constexpr int32_t kMaxHuberIterations = 15;
constexpr double kHuberStepTolerance_m = 1e-3;
static_assert(kMaxHuberIterations <= kMaxSitePoseIterations, "the Huber solve is one of the bounded solves");
// Resection of a new site (warm start): Gauss-Newton steps on its 6 unknowns, until its step is below this
// (metres at the nominal range), and the fewest observations it takes (3 points' worth).
constexpr int32_t kMaxResectionIterations = 10;
constexpr double kResectionStepTolerance_m = 1e-4;
constexpr double kResectionRange_m = 10.0;  // the range at which its rotation step is taken as metres
constexpr int32_t kMinResectionObservations = 6;
// An orthonormal rotation to this tolerance (input check).
constexpr double kRotationTolerance = 1e-6;

bool finitePose(const TraverseFromSite& pose) {
  return pose.position_m.allFinite() && pose.rotation.allFinite();
}

bool rotationMatrix(const Mat3& m) {
  if (!m.allFinite()) return false;
  Mat3 d;
  d.noalias() = m * m.transpose();
  d -= Mat3::Identity();
  return d.cwiseAbs().maxCoeff() < kRotationTolerance && m.determinant() > 0.0;
}

bool positiveFinite(const Vec3& v) {
  return v.allFinite() && v.minCoeff() > 0.0;
}

}  // namespace

const char* siteLinkName(SiteLink link) {
  switch (link) {
    case SiteLink::kHeld:
      return "held";
    case SiteLink::kTied:
      return "tied";
    case SiteLink::kNoOverlap:
      return "no_overlap";
  }
  return "unknown";
}

template <typename C>
void BasicSitePoseAdjuster<C>::clear() {
  site_count_ = 0;
  camera_count_ = 0;
  point_count_ = 0;
  observation_count_ = 0;
  first_free_ = 1;
  for (int32_t& e : input_errors_) e = 0;
}

template <typename C>
Status BasicSitePoseAdjuster<C>::refuse(Status status) {
  ++input_errors_[static_cast<int32_t>(status)];
  return status;
}

template <typename C>
int32_t BasicSitePoseAdjuster<C>::inputErrorTotal() const {
  int32_t total = 0;
  for (const int32_t e : input_errors_) total += e;
  return total;
}

template <typename C>
Status BasicSitePoseAdjuster<C>::addFirstSite(const TraverseFromSite& datum, int32_t& site) {
  site = -1;
  if (site_count_ != 0) return refuse(Status::kInvalidArgument);
  if (!finitePose(datum)) return refuse(Status::kNotFinite);
  if (!rotationMatrix(datum.rotation)) return refuse(Status::kInvalidArgument);
  SiteState& s = sites_[0];
  s = SiteState{};
  s.pose = datum;
  s.apriori = datum;
  site = site_count_++;
  return Status::kOk;
}

template <typename C>
Status BasicSitePoseAdjuster<C>::addSite(const LegMeasurement& leg, const TraverseFromSite* apriori,
                                         int32_t& site) {
  site = -1;
  if (site_count_ == 0) return refuse(Status::kMissingField);
  if (site_count_ >= C::kSites) return refuse(Status::kCapacityExceeded);
  if (!leg.delta_position_m.allFinite() || !leg.delta_rotation.allFinite() ||
      !leg.sigma_position_m.allFinite() || !leg.sigma_rotation_rad.allFinite())
    return refuse(Status::kNotFinite);
  if (!positiveFinite(leg.sigma_position_m) || !positiveFinite(leg.sigma_rotation_rad) ||
      !rotationMatrix(leg.delta_rotation))
    return refuse(Status::kInvalidArgument);
  if (apriori != nullptr && !finitePose(*apriori)) return refuse(Status::kNotFinite);
  if (apriori != nullptr && !rotationMatrix(apriori->rotation)) return refuse(Status::kInvalidArgument);
  SiteState& s = sites_[site_count_];
  s = SiteState{};
  s.leg = leg;
  if (apriori != nullptr) {
    s.apriori = *apriori;
  } else {
    const TraverseFromSite& prev = sites_[site_count_ - 1].pose;
    s.apriori.position_m = prev.position_m;
    s.apriori.position_m.noalias() += prev.rotation * leg.delta_position_m;
    s.apriori.rotation.noalias() = prev.rotation * leg.delta_rotation;
  }
  s.pose = s.apriori;
  site = site_count_++;
  return Status::kOk;
}

template <typename C>
Status BasicSitePoseAdjuster<C>::addCamera(int32_t site, const InteriorOrientation& io,
                                           const Vec3& center_in_site_m, const Mat3& m_site,
                                           int32_t& camera) {
  camera = -1;
  if (site < 0 || site >= site_count_) return refuse(Status::kInvalidArgument);
  if (camera_count_ >= C::kCameras) return refuse(Status::kCapacityExceeded);
  if (!std::isfinite(io.f_px) || !std::isfinite(io.x0_px) || !std::isfinite(io.y0_px) ||
      !center_in_site_m.allFinite() || !m_site.allFinite())
    return refuse(Status::kNotFinite);
  if (!(io.f_px > 0.0) || !rotationMatrix(m_site)) return refuse(Status::kInvalidArgument);
  SiteCamera& c = cameras_[camera_count_];
  c.site = site;
  c.io = io;
  c.center_in_site_m = center_in_site_m;
  c.m_site = m_site;
  camera = camera_count_++;
  return Status::kOk;
}

template <typename C>
Status BasicSitePoseAdjuster<C>::addPoint(const Vec3* xyz_m, int32_t& point) {
  point = -1;
  if (point_count_ >= C::kPoints) return refuse(Status::kCapacityExceeded);
  if (xyz_m != nullptr && !xyz_m->allFinite()) return refuse(Status::kNotFinite);
  CrossSitePoint& p = points_[point_count_];
  p = CrossSitePoint{};
  if (xyz_m != nullptr) {
    p.xyz_m = *xyz_m;
    p.placed = true;
    p.placed_by = -1;
  }
  point = point_count_++;
  return Status::kOk;
}

template <typename C>
Status BasicSitePoseAdjuster<C>::addObservation(int32_t point, int32_t camera, const Vec2& ideal_px,
                                                double sigma_px) {
  if (point < 0 || point >= point_count_ || camera < 0 || camera >= camera_count_)
    return refuse(Status::kInvalidArgument);
  if (!ideal_px.allFinite() || !std::isfinite(sigma_px)) return refuse(Status::kNotFinite);
  if (!(sigma_px > 0.0)) return refuse(Status::kInvalidArgument);
  CrossSitePoint& p = points_[point];
  for (int32_t k = 0; k < p.obs_count; ++k) {
    if (observations_[p.obs[k]].camera == camera) return refuse(Status::kInvalidArgument);
  }
  if (p.obs_count >= kMaxObsPerCrossSitePoint || observation_count_ >= C::kObservations)
    return refuse(Status::kCapacityExceeded);
  CrossSiteObservation& o = observations_[observation_count_];
  o.point = point;
  o.camera = camera;
  o.ideal_px = ideal_px;
  o.sigma_px = sigma_px;
  o.rejected = false;
  p.obs[p.obs_count++] = observation_count_++;
  return Status::kOk;
}

template <typename C>
void BasicSitePoseAdjuster<C>::resetToApriori() {
  for (int32_t k = 0; k < site_count_; ++k) {
    sites_[k].pose = sites_[k].apriori;
    sites_[k].covariance.setZero();
    sites_[k].sigma.setZero();
    sites_[k].solved = false;
  }
  for (int32_t p = 0; p < point_count_; ++p) points_[p].placed = false;
  for (int32_t o = 0; o < observation_count_; ++o) observations_[o].rejected = false;
}

template <typename C>
bool BasicSitePoseAdjuster<C>::usable(const CrossSiteObservation& o) const {
  return !o.rejected && inSolve(points_[o.point]);
}

template <typename C>
Status BasicSitePoseAdjuster<C>::observationError(int32_t o, Vec2& error) const {
  if (o < 0 || o >= observation_count_) return Status::kInvalidArgument;
  return observationRows(observations_[o], error, nullptr, nullptr);
}

template <typename C>
Status BasicSitePoseAdjuster<C>::observationRows(const CrossSiteObservation& o, Vec2& error, Mat2x6* d_pose,
                                                 Mat2x3* d_point) const {
  const SiteCamera& c = cameras_[o.camera];
  return crossSiteObservationRow(sites_[c.site].pose, c, points_[o.point].xyz_m, o.ideal_px, o.sigma_px,
                                 error, d_pose, d_point);
}

template <typename C>
double BasicSitePoseAdjuster<C>::cost(double* rms_px, int32_t* active) const {
  double total = 0.0;
  double pixel_sq = 0.0;
  int32_t n = 0;
  for (int32_t o = 0; o < observation_count_; ++o) {
    const CrossSiteObservation& ob = observations_[o];
    if (!usable(ob)) continue;
    Vec2 e;
    if (!ok(observationError(o, e))) {
      total += kBehindCameraCost;
      continue;
    }
    const double sq = e.squaredNorm();
    const double norm = std::sqrt(sq);
    total += huber_ > 0.0 && norm > huber_ ? 2.0 * huber_ * norm - huber_ * huber_ : sq;
    pixel_sq += sq * ob.sigma_px * ob.sigma_px;
    ++n;
  }
  for (int32_t k = 1; k < site_count_; ++k) {
    if (!legActive(k)) continue;
    Vec6 e;
    odometryRows(sites_[k - 1].pose, sites_[k].pose, sites_[k].leg, e, nullptr, nullptr);
    total += e.squaredNorm();
  }
  if (rms_px != nullptr) *rms_px = n > 0 ? std::sqrt(pixel_sq / (2.0 * n)) : 0.0;
  if (active != nullptr) *active = n;
  return total;
}

template <typename C>
int32_t BasicSitePoseAdjuster<C>::raysInFront(const CrossSitePoint& pt, const Vec3& xyz) const {
  int32_t front = 0;
  for (int32_t k = 0; k < pt.obs_count; ++k) {
    const CrossSiteObservation& o = observations_[pt.obs[k]];
    if (o.rejected) continue;
    Vec3 center;
    Mat3 m;
    cameraInTraverse(sites_[cameras_[o.camera].site].pose, cameras_[o.camera], center, m);
    Vec3 d;
    d.noalias() = m * (xyz - center);
    front += d.z() < 0.0 ? 1 : 0;
  }
  return front;
}

template <typename C>
bool BasicSitePoseAdjuster<C>::placePoint(int32_t p) {
  CrossSitePoint& pt = points_[p];
  // Candidates: the intersection of the rays of each site with two or more (its cameras' relative EO is
  // exact, the single-site adjustment, so they meet where the point is in that site's frame), and of all
  // rays. Kept: the one in front of the most cameras (a gross error along a short stereo base can throw a
  // two-ray point behind the cameras), then the one of a site whose pose is better than odometry (a site
  // added to a solved traverse starts from points placed by its solved neighbours: the warm start), then
  // the most rays.
  int32_t site_rays[C::kSites] = {};
  int32_t total = 0;
  for (int32_t k = 0; k < pt.obs_count; ++k) {
    const CrossSiteObservation& o = observations_[pt.obs[k]];
    if (o.rejected) continue;
    ++site_rays[cameras_[o.camera].site];
    ++total;
  }
  if (total < 2) return false;
  Vec3 origins[kMaxObsPerCrossSitePoint];
  Vec3 directions[kMaxObsPerCrossSitePoint];
  int32_t best_front = -1, best_rays = 0, best_site = -1;
  bool best_good = false;
  Vec3 best_xyz = Vec3::Zero();
  // candidate site_count_: all rays.
  for (int32_t cand = 0; cand <= site_count_; ++cand) {
    const bool all = cand == site_count_;
    if (!all && site_rays[cand] < 2) continue;
    int32_t n = 0;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const CrossSiteObservation& o = observations_[pt.obs[k]];
      const SiteCamera& c = cameras_[o.camera];
      if (o.rejected || (!all && c.site != cand)) continue;
      Mat3 m;
      cameraInTraverse(sites_[c.site].pose, c, origins[n], m);
      directions[n] = rayOfIdealPixel(c.io, m, o.ideal_px);
      ++n;
    }
    Vec3 xyz;
    if (!ok(intersectRays(origins, directions, n, xyz)) || !xyz.allFinite()) continue;
    const int32_t front = raysInFront(pt, xyz);
    const bool good = !all && goodPose(cand);
    const bool better =
        front > best_front ||
        (front == best_front && ((good && !best_good) || (good == best_good && n > best_rays)));
    if (!better) continue;
    best_front = front;
    best_good = good;
    best_rays = n;
    best_site = all ? -1 : cand;
    best_xyz = xyz;
  }
  if (best_front < 0) return false;
  pt.xyz_m = best_xyz;
  pt.placed = true;
  pt.placed_by = best_site;
  return true;
}

template <typename C>
void BasicSitePoseAdjuster<C>::preparePoints() {
  for (int32_t p = 0; p < point_count_; ++p) {
    CrossSitePoint& pt = points_[p];
    int32_t active = 0;
    for (int32_t k = 0; k < pt.obs_count; ++k) active += observations_[pt.obs[k]].rejected ? 0 : 1;
    if (active >= 2 && (!pt.placed || !pt.xyz_m.allFinite())) pt.placed = placePoint(p);
    pt.solvable = active >= 2 && pt.placed && pt.xyz_m.allFinite();
    pt.in_window = false;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const CrossSiteObservation& o = observations_[pt.obs[k]];
      pt.in_window = pt.in_window || (!o.rejected && freeSite(cameras_[o.camera].site));
    }
  }
}

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
bool BasicSitePoseAdjuster<C>::resect(int32_t site, int32_t& iterations) {
  for (int32_t it = 0; it < kMaxResectionIterations; ++it) {
    Mat6 n = Mat6::Zero();
    Vec6 g = Vec6::Zero();
    int32_t rows = 0;
    for (int32_t o = 0; o < observation_count_; ++o) {
      const CrossSiteObservation& ob = observations_[o];
      const SiteCamera& c = cameras_[ob.camera];
      const CrossSitePoint& pt = points_[ob.point];
      if (c.site != site || ob.rejected || !pt.placed || pt.placed_by < 0 || pt.placed_by == site ||
          !goodPose(pt.placed_by))
        continue;
      Vec2 e;
      Mat2x6 j;
      if (!ok(observationRows(ob, e, &j, nullptr))) continue;
      n.noalias() += j.transpose() * j;
      g.noalias() -= j.transpose() * e;
      ++rows;
    }
    if (rows < kMinResectionObservations) return false;
    Vec6 e;
    Mat6 ja, jb;
    odometryRows(sites_[site - 1].pose, sites_[site].pose, sites_[site].leg, e, &ja, &jb);
    n.noalias() += jb.transpose() * jb;
    g.noalias() -= jb.transpose() * e;
    const Eigen::LDLT<Mat6> ldlt(n);
    if (ldlt.info() != Eigen::Success) return false;
    const Vec6 step = ldlt.solve(g);
    if (!step.allFinite()) return false;
    applySiteUpdate(step, sites_[site].pose);
    ++iterations;
    if (step.head<3>().norm() + kResectionRange_m * step.tail<3>().norm() < kResectionStepTolerance_m) break;
  }
  return true;
}

template <typename C>
void BasicSitePoseAdjuster<C>::resectNewSites(SitePoseResult& result) {
  for (int32_t k = first_free_; k < site_count_; ++k) {
    if (sites_[k].solved || !(sites_[k - 1].solved || resected_[k - 1])) continue;
    const TraverseFromSite start = sites_[k].pose;
    if (!resect(k, result.resection_iterations)) {
      sites_[k].pose = start;  // no ties to solved sites: it stays where odometry put it
      continue;
    }
    resected_[k] = true;
    ++result.resected_sites;
    for (int32_t p = 0; p < point_count_; ++p) {
      CrossSitePoint& pt = points_[p];
      if (pt.placed && pt.placed_by == k && !placePoint(p)) pt.placed = false;
    }
  }
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

template <typename C>
Status BasicSitePoseAdjuster<C>::adjust(const SitePoseOptions& options, SitePoseResult& result) {
  result = SitePoseResult{};
  if (site_count_ == 0) {
    result.status = refuse(Status::kMissingField);
    return result.status;
  }
  if (options.window_sites < 0 || options.max_iterations < 1 ||
      options.max_iterations > kMaxSitePoseIterations || !(options.step_tolerance_m > 0.0) ||
      !(options.nominal_range_m > 0.0)) {
    result.status = refuse(Status::kInvalidArgument);
    return result.status;
  }
  first_free_ = options.window_sites > 0 ? std::max(1, site_count_ - options.window_sites) : 1;
  result.first_free_site = first_free_;
  result.free_sites = std::max(0, site_count_ - first_free_);
  for (bool& r : resected_) r = false;
  if (options.robust) readmitWindowObservations();
  preparePoints();
  resectNewSites(result);
  preparePoints();
  result.initial_cost = cost();
  if (options.robust && options.huber_sigma > 0.0) {
    // A first solve under the Huber loss, so that gross errors do not drag the points and poses that the
    // rejection then judges them by.
    // Its reweighted steps converge linearly; it only has to bring the state near the inliers' minimum.
    SitePoseOptions rough = options;
    rough.max_iterations = std::min(options.max_iterations, kMaxHuberIterations);
    rough.step_tolerance_m = std::max(options.step_tolerance_m, kHuberStepTolerance_m);
    huber_ = options.huber_sigma;
    const Status s = solve(rough, result);
    huber_ = 0.0;
    if (!ok(s)) {
      result.status = s;
      return s;
    }
    result.rejected_observations += rejectOutliers(options);
    result.rejection_rounds += result.rejected_observations > 0 ? 1 : 0;
  }
  for (int32_t round = 0; round <= kMaxRejectionRounds; ++round) {
    preparePoints();
    const Status s = solve(options, result);
    if (!ok(s)) {
      result.status = s;
      return s;
    }
    if (!options.robust || round == kMaxRejectionRounds) break;
    const int32_t rejected = rejectOutliers(options);
    if (rejected == 0) break;
    result.rejected_observations += rejected;
    ++result.rejection_rounds;
  }
  preparePoints();
  for (int32_t k = 0; k < site_count_; ++k) sites_[k].solved = true;
  linkStatus(result);
  result.status = precision(result, options.covariance);
  return result.status;
}

template class BasicSitePoseAdjuster<TraverseCapacity<kMaxSites>>;
template class BasicSitePoseAdjuster<TraverseCapacity<kMaxGroundSites>>;

}  // namespace areomap
