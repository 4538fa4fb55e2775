#include "firmware_core/node/RoverTraverse.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>

#include "firmware_core/base/Angles.hpp"
#include "msgs/adapters/MessageAdapters.hpp"

namespace areomap {
namespace {

// The tilt sigma of a leg between two levelled site frames: the rover's accelerometers level each frame
// far better than wheel odometry measures heading (the ground's kLevelSigmaRad, CrossSiteAdjustment.hpp).
constexpr double kRoverLevelSigmaRad = 1e-3;
// The sigma of a tie observation (pixels of the matcher's frame): as the panorama's ties (NetworkBuilder);
// a cross-site match found in a binned kept image counts its binning.
constexpr double kRoverTieSigmaPx = 0.3;

Mat3 headingRotation(double heading_deg) {
  const double h = heading_deg * kDegToRad;
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
  return std::atan2(rotation(1, 0), rotation(0, 0)) / kDegToRad;
}

void RoverTraverse::reset() {
  adjuster_.clear();
  for (int32_t r = 0; r < 2; ++r) {
    records_[r].reset();
    camera_count_[r] = 0;
    captured_[r] = false;
  }
  current_ = 0;
  leg_ = RoverLegReport{};
  site_count_ = 0;
  first_published_ = 0;
  traverse_[0] = '\0';
  pending_ = false;
  counters_ = RoverTraverseCounters{};
}

void RoverTraverse::announce(const site_t& site) {
  pending_ = true;
  records_[current_].reset();
  camera_count_[current_] = 0;
  captured_[current_] = false;
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
      Vec3(kRoverLevelSigmaRad, kRoverLevelSigmaRad, site.sigma_heading_deg * kDegToRad);
  pending_apriori_.position_m = Vec3(site.position_m[0], site.position_m[1], site.position_m[2]);
  pending_apriori_.rotation = headingRotation(site.heading_deg);
}

Status RoverTraverse::refuse(Status cause) {
  const int32_t c = static_cast<int32_t>(cause);
  if (c > 0 && c < static_cast<int32_t>(Status::kCount)) counters_.refused_by_cause[c] += 1;
  counters_.sites_refused += 1;
  return cause;
}

void RoverTraverse::keepImage(const ImageView& image, int32_t net_image, const CameraModel& apriori_model,
                              const PhotogrammetricCamera& apriori_camera) {
  if (pending_) (void)records_[current_].keepImage(image, net_image, apriori_model, apriori_camera);
}

Status RoverTraverse::finishSite(const Network* net, const NetworkBuilder* builder) {
  if (!pending_) return refuse(Status::kMissingField);
  pending_ = false;
  if (net != nullptr && builder != nullptr && net->pairCount() > 0) capture(*net, *builder);
  const int32_t record = current_;
  current_ = 1 - current_;  // this site's record is the previous one of the next site
  leg_ = RoverLegReport{};
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
  if (captured_[record] && captured_[1 - record]) {
    tieLeg(record, previous->adjuster_site, s);
    rec.registration = leg_.registration.status == DemRegistrationStatus::kOk
                           ? site_pose_t::REGISTRATION_OK
                           : site_pose_t::REGISTRATION_REFUSED;
  }
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

namespace areomap {

void describeLeg(const RoverLegReport& leg, char* out, int32_t size) {
  if (size <= 0) return;
  const CrossMatchCounts& c = leg.counts;
  std::snprintf(out, static_cast<std::size_t>(size),
                "DEM registration %s (%d samples, %.3f m RMS), %d cross-site ties (%d candidates, %d "
                "predictions; refused: %d low NCC, %d ambiguous, %d peak on the edge, %d scale, %d grazing, %d "
                "beyond range, %d off the DEM, %d warp), %d observations into the site-pose adjustment",
                demRegistrationStatusName(leg.registration.status), static_cast<int>(leg.registration.overlap),
                leg.registration.rms_m, static_cast<int>(leg.ties), static_cast<int>(leg.candidates_a),
                static_cast<int>(c.predicted), static_cast<int>(c.low_ncc), static_cast<int>(c.ambiguous),
                static_cast<int>(c.edge_peak), static_cast<int>(c.scale_gate), static_cast<int>(c.grazing),
                static_cast<int>(c.beyond_range), static_cast<int>(c.outside), static_cast<int>(c.warp_failed),
                static_cast<int>(leg.observations_added));
}

void RoverTraverse::capture(const Network& net, const NetworkBuilder& builder) {
  CrossSiteRecord& rec = records_[current_];
  rec.dem().reset(Vec3::Zero());
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    const NetPoint& pt = net.point(p);
    if (pt.solvable && pt.obs_count >= 2) (void)rec.dem().addPoint(pt.xyz_m);
  }
  (void)rec.dem().finish();
  const int32_t images = net.imageCount() < kMaxImages ? net.imageCount() : kMaxImages;
  for (int32_t i = 0; i < images; ++i) {
    const NetImage& im = net.image(i);
    cameras_[current_][i] = RoverSiteCamera{im.io, im.centre_m, im.m, -1};
  }
  camera_count_[current_] = images;
  for (int32_t k = 0; k < rec.imageCount(); ++k) {
    const int32_t i = rec.image(k).image;
    if (i < 0 || i >= images) continue;
    const NetImage& im = net.image(i);
    rec.setAdjustedModel(k, adjustedModel(builder.model(i), im.m_apriori, im.m, im.centre_m));
  }
  // Candidates: adjusted points seen in a kept image, spread by its grid.
  for (int32_t p = 0; p < net.pointCount() && rec.candidateCount() < kMaxSiteCandidates; ++p) {
    const NetPoint& pt = net.point(p);
    if (!pt.solvable || pt.obs_count < 2) continue;
    CrossSiteCandidate c;
    c.xyz_m = pt.xyz_m;
    int32_t kept = -1;
    for (int32_t j = 0; j < pt.obs_count && c.observation_count < kMaxCandidateObservations; ++j) {
      const NetObservation& o = net.observation(pt.obs[j]);
      if (o.rejected || o.image < 0 || o.image >= images) continue;
      if (kept < 0) kept = rec.storedOf(o.image);
      c.image[c.observation_count] = o.image;
      c.ideal_px[c.observation_count] = o.ideal_px;
      c.observation_count += 1;
    }
    if (kept < 0 || c.observation_count < 2) continue;
    Vec2 px;
    if (!ok(project(rec.image(kept).model, c.xyz_m, px))) continue;
    (void)rec.offerCandidate(kept, px, c);
  }
  captured_[current_] = true;
}

int32_t RoverTraverse::cameraFor(int32_t record, int32_t site, int32_t image) {
  if (image < 0 || image >= camera_count_[record]) return -1;
  RoverSiteCamera& c = cameras_[record][image];
  if (c.adjuster_camera < 0) {
    int32_t index = -1;
    if (ok(adjuster_.addCamera(site, c.io, c.centre_m, c.m, index))) c.adjuster_camera = index;
  }
  return c.adjuster_camera;
}

// The leg from the previous site (record 1 - record_b, adjuster site site_a) into this one: B's DEM
// registered onto A's about the odometry (its search window 3 sigmas of the leg, within the ground's 2-6 m
// and 5-12 degrees), A's candidates matched in B's kept images, each tie a point of the adjuster with A's
// observations and B's.
void RoverTraverse::tieLeg(int32_t record_b, int32_t site_a, int32_t site_b) {
  const int32_t record_a = 1 - record_b;
  const CrossSiteRecord& a = records_[record_a];
  const CrossSiteRecord& b = records_[record_b];
  LevelledPose apriori;
  apriori.translation_m = pending_leg_.delta_position_m;
  apriori.heading_rad = std::atan2(pending_leg_.delta_rotation(1, 0), pending_leg_.delta_rotation(0, 0));
  DemRegistrationParams params;
  const double sigma_m = std::max(pending_leg_.sigma_position_m.x(), pending_leg_.sigma_position_m.y());
  params.search_m = std::min(6.0, std::max(2.0, 3.0 * sigma_m));
  params.search_deg = std::min(12.0, std::max(5.0, 3.0 * pending_leg_.sigma_rotation_rad.z() / kDegToRad));
  leg_.candidates_a = a.candidateCount();
  leg_.kept_images_b = b.imageCount();
  leg_.registration = registration_.run(a.dem(), b.dem(), apriori, params);
  if (leg_.registration.status != DemRegistrationStatus::kOk) return;
  int32_t count = 0;
  matcher_.match(a, b, leg_.registration.a_from_b, CrossMatchParams{}, ties_, kMaxCrossSiteTiesPerLeg, count,
                 leg_.counts);
  leg_.ties = count;
  int32_t point = -1, point_candidate = -1;
  for (int32_t t = 0; t < count; ++t) {
    const RoverCrossTie& tie = ties_[t];
    const CrossSiteCandidate& c = a.candidate(tie.candidate);
    if (tie.candidate != point_candidate) {
      point_candidate = tie.candidate;
      if (!ok(adjuster_.addPoint(nullptr, point))) {
        point = -1;
        leg_.observations_refused += 1;
        continue;
      }
      for (int32_t j = 0; j < c.observation_count; ++j) {
        const int32_t cam = cameraFor(record_a, site_a, c.image[j]);
        const bool added = cam >= 0 && ok(adjuster_.addObservation(point, cam, c.ideal_px[j], kRoverTieSigmaPx));
        (added ? leg_.observations_added : leg_.observations_refused) += 1;
      }
    }
    if (point < 0) continue;
    const KeptImage& kept = b.image(tie.stored);
    Vec2 ideal;
    const int32_t cam = cameraFor(record_b, site_b, kept.image);
    const bool added = cam >= 0 && ok(pixelToIdeal(kept.apriori_model, kept.apriori_camera, tie.matcher_px, ideal)) &&
                       ok(adjuster_.addObservation(point, cam, ideal, kRoverTieSigmaPx * kept.bin));
    (added ? leg_.observations_added : leg_.observations_refused) += 1;
  }
}

}  // namespace areomap
