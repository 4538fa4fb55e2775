#include "firmware_core/node/RoverTraverse.hpp"

#include <cmath>
#include <cstring>

#include "msgs/adapters/MessageAdapters.hpp"

namespace areomap {
namespace {

constexpr double kRoverDegToRad = 3.14159265358979323846 / 180.0;
// The tilt sigma of a leg between two levelled site frames: the rover's accelerometers level each frame
// far better than wheel odometry measures heading (the ground's kLevelSigmaRad, CrossSiteAdjustment.hpp).
constexpr double kRoverLevelSigmaRad = 1e-3;

Mat3 headingRotation(double heading_deg) {
  const double h = heading_deg * kRoverDegToRad;
  const double c = std::cos(h), s = std::sin(h);
  Mat3 r;
  r << c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0;
  return r;
}

TraverseFromSite compose(const TraverseFromSite& a, const LegMeasurement& leg) {
  TraverseFromSite b;
  b.position_m.noalias() = a.position_m + a.rotation * leg.delta_position_m;
  b.rotation.noalias() = a.rotation * leg.delta_rotation;
  return b;
}

// The covariance of a pose update of `site` caused by an update [dp, dtheta] of `held` (both traverse
// frame): dp_site = dp + dtheta x (p_site - p_held), dtheta_site = dtheta.
Mat6 carried(const Mat6& held_cov, const Vec3& held_p, const Vec3& site_p) {
  Mat6 j = Mat6::Identity();
  const Vec3 r = site_p - held_p;
  Mat3 skew;
  skew << 0.0, -r.z(), r.y(), r.z(), 0.0, -r.x(), -r.y(), r.x(), 0.0;
  j.block<3, 3>(0, 3) = -skew;
  Mat6 out;
  out.noalias() = j * held_cov * j.transpose();
  return out;
}

}  // namespace

double headingDegOf(const Mat3& rotation) {
  return std::atan2(rotation(1, 0), rotation(0, 0)) / kRoverDegToRad;
}

void RoverTraverse::reset() {
  adjuster_.clear();
  site_count_ = 0;
  first_published_ = 0;
  traverse_[0] = '\0';
  pending_ = false;
  counters_ = RoverTraverseCounters{};
}

void RoverTraverse::announce(const site_t& site) {
  pending_ = true;
  pending_record_ = RoverSiteRecord{};
  copyText(site.site_id.c_str(), pending_record_.site_id, sizeof(pending_record_.site_id));
  copyText(site.panorama.c_str(), pending_record_.panorama, sizeof(pending_record_.panorama));
  copyText(site.odometry_from.c_str(), pending_from_, sizeof(pending_from_));
  copyText(site.traverse.c_str(), traverse_, sizeof(traverse_));
  pending_record_.site_index = site.site_index;
  pending_has_leg_ = site.has_odometry;
  pending_leg_ = LegMeasurement{};
  pending_leg_distance_m_ = site.distance_m;
  pending_leg_.delta_position_m = Vec3(site.delta_m[0], site.delta_m[1], site.delta_m[2]);
  pending_leg_.delta_rotation = headingRotation(site.delta_heading_deg);
  pending_leg_.sigma_position_m = Vec3(site.sigma_m[0], site.sigma_m[1], site.sigma_m[2]);
  pending_leg_.sigma_rotation_rad =
      Vec3(kRoverLevelSigmaRad, kRoverLevelSigmaRad, site.sigma_heading_deg * kRoverDegToRad);
  pending_apriori_.position_m = Vec3(site.position_m[0], site.position_m[1], site.position_m[2]);
  pending_apriori_.rotation = headingRotation(site.heading_deg);
}

Status RoverTraverse::refuse(Status cause) {
  const int32_t c = static_cast<int32_t>(cause);
  if (c > 0 && c < static_cast<int32_t>(Status::kCount)) counters_.refused_by_cause[c] += 1;
  counters_.sites_refused += 1;
  return cause;
}

Status RoverTraverse::finishSite() {
  if (!pending_) return refuse(Status::kMissingField);
  pending_ = false;
  if (site_count_ >= kMaxSites) return refuse(Status::kCapacityExceeded);
  RoverSiteRecord& rec = sites_[site_count_];
  rec = pending_record_;
  const bool first = !pending_has_leg_;
  const RoverSiteRecord* previous = site_count_ > 0 ? &sites_[site_count_ - 1] : nullptr;
  // A leg must come from the site before, which the adjustment holds; a first site starts a traverse.
  const bool chained = previous != nullptr && previous->adjuster_site >= 0 &&
                       std::strcmp(previous->site_id, pending_from_) == 0;
  if (first) {
    adjuster_.clear();  // a new traverse from its first site (the counters go on)
    RoverSiteRecord& head = sites_[0];
    head = pending_record_;
    head.odometry = pending_apriori_;
    head.pose = pending_apriori_;
    head.status = site_pose_t::STATUS_DATUM;
    int32_t s = -1;
    site_count_ = 1;
    first_published_ = 0;
    if (!ok(adjuster_.addFirstSite(pending_apriori_, s))) {
      head.status = site_pose_t::STATUS_FAILED;
      return refuse(Status::kInvalidArgument);
    }
    head.adjuster_site = s;
    counters_.sites_adjusted += 1;
    return Status::kOk;
  }
  rec.distance_m = (previous != nullptr ? previous->distance_m : 0.0) + pending_leg_distance_m_;
  rec.odometry = previous != nullptr ? compose(previous->odometry, pending_leg_) : pending_apriori_;
  rec.pose = rec.odometry;
  rec.status = site_pose_t::STATUS_FAILED;
  site_count_ += 1;
  first_published_ = site_count_ - 1;
  if (!chained) return refuse(Status::kInvalidArgument);
  int32_t s = -1;
  const Status added = adjuster_.addSite(pending_leg_, nullptr, s);
  if (!ok(added)) return refuse(added);
  rec.adjuster_site = s;
  counters_.sites_adjusted += 1;
  solveWindow();
  return Status::kOk;
}

void RoverTraverse::solveWindow() {
  SitePoseOptions options;
  options.window_sites = kRoverWindowSites;
  SitePoseResult result;
  const Status s = adjuster_.adjust(options, result);
  counters_.last_iterations = result.iterations_total;
  counters_.last_sigma0 = result.sigma0;
  counters_.last_window_sites = result.free_sites;
  if (!ok(s)) counters_.adjust_failures += 1;
  // The records of the adjuster's sites (the traverse's records from the datum on are its sites in order).
  const int32_t first_free = result.first_free_site;
  const int32_t held = first_free - 1;  // the last held site: the window's anchor
  first_published_ = held >= 0 ? held : 0;
  for (int32_t k = first_published_; k < site_count_; ++k) {
    RoverSiteRecord& rec = sites_[k];
    if (rec.adjuster_site < 0) continue;
    const SiteState& st = adjuster_.site(rec.adjuster_site);
    rec.tie_observations = st.tie_observations;
    if (!ok(s)) {
      if (rec.adjuster_site >= first_free) rec.status = site_pose_t::STATUS_FAILED;
      continue;
    }
    rec.pose = st.pose;
    if (rec.adjuster_site == 0) {
      rec.status = site_pose_t::STATUS_DATUM;
    } else if (rec.adjuster_site < first_free) {
      rec.status = site_pose_t::STATUS_HELD;  // its covariance: the last one it had while free
    } else {
      rec.status = st.link == SiteLink::kTied ? site_pose_t::STATUS_TIED : site_pose_t::STATUS_ODOMETRY;
      rec.covariance = st.covariance;
      if (held > 0) rec.covariance += carried(sites_[held].covariance, sites_[held].pose.position_m, st.pose.position_m);
    }
  }
}

}  // namespace areomap
