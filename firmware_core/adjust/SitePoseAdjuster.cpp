// The traverse adjuster's input and its adjust() (SitePoseAdjuster.hpp): sites, cameras, points and
// observations checked and refused with a counted Status, and adjust()'s order of solves (warm start, the
// Huber solve, the rejection rounds, each site's link and precision). The state and the warm start are in
// SitePosePoints.cpp, the solve in SitePoseSolve.cpp; each instantiates its members for both capacities.
#include "firmware_core/adjust/SitePoseAdjuster.hpp"

#include <algorithm>
#include <cmath>

#include "firmware_core/adjust/FastAdjustOptions.hpp"  // kMaxRejectionRounds, shared with the fast adjuster

namespace areomap {

// The traverse adjuster is a rover-side static object beside the fast adjuster and its network.
static_assert(sizeof(SitePoseAdjuster) < kStaticMemoryBudgetBytes / 16,
              "the traverse adjuster must stay a small part of the rover's static memory budget");

namespace {

// The Huber solve before the rejection rounds: bounded, and stopped at a millimetre step.
constexpr int32_t kMaxHuberIterations = 15;
constexpr double kHuberStepTolerance_m = 1e-3;
static_assert(kMaxHuberIterations <= kMaxSitePoseIterations, "the Huber solve is one of the bounded solves");
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
                                           const Vec3& centre_in_site_m, const Mat3& m_site,
                                           int32_t& camera) {
  camera = -1;
  if (site < 0 || site >= site_count_) return refuse(Status::kInvalidArgument);
  if (camera_count_ >= C::kCameras) return refuse(Status::kCapacityExceeded);
  if (!std::isfinite(io.f_px) || !std::isfinite(io.x0_px) || !std::isfinite(io.y0_px) ||
      !centre_in_site_m.allFinite() || !m_site.allFinite())
    return refuse(Status::kNotFinite);
  if (!(io.f_px > 0.0) || !rotationMatrix(m_site)) return refuse(Status::kInvalidArgument);
  SiteCamera& c = cameras_[camera_count_];
  c.site = site;
  c.io = io;
  c.centre_in_site_m = centre_in_site_m;
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
