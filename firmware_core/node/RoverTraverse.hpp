// The rover's own traverse: after each announced site's panorama, the site enters the site-pose adjustment
// (firmware_core/adjust/SitePoseAdjuster.hpp) tied to the site before it by its odometry leg (AREOMAP_SITE)
// and, where the rover finds them, by cross-site ties (CrossSiteMatcher.hpp, between the site just mapped and
// the one before it); the last kRoverWindowSites sites are solved, the earlier ones held. The result of
// each site of the window is what AREOMAP_SITE_POSE carries.
//
// Covariance: the adjuster's is conditional on the held sites. A site leaving the window keeps its last
// absolute covariance; a free site's absolute covariance adds the first held site's, carried rigidly to it
// (a rotation dtheta about the held site moves the site by dtheta x (p - p_held)).
//
// Bad input (a leg from a site other than the previous one, a traverse beyond kMaxSites) is refused with a
// counted Status: the site is then not adjusted and its pose is the odometry chain's (STATUS_FAILED).
// Memory: fixed (the adjuster ~2.7 MiB); no heap.
#pragma once

#include <cstdint>

#include "areomap/site_pose_t.hpp"
#include "areomap/site_t.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/adjust/NetworkBuilder.hpp"
#include "firmware_core/adjust/SitePoseAdjuster.hpp"
#include "firmware_core/dem/CoarseDemRegistration.hpp"
#include "firmware_core/match/CrossSiteMatcher.hpp"
#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/Status.hpp"

namespace areomap {

// Sites the rover solves after each site: the last 4 (a leg's ties reach the site before it; four sites
// let a tie correct the legs before it while the solve stays a few 24 x 24 blocks).
constexpr int32_t kRoverWindowSites = 4;
// Strings of a site kept by the traverse (site id, panorama): as the messages' strings.
constexpr int32_t kMaxRoverSiteChars = 128;

struct RoverSiteRecord {
  char site_id[kMaxRoverSiteChars + 1] = {0};
  char panorama[kMaxRoverSiteChars + 1] = {0};
  int32_t site_index = 0;       // in driving order, as announced
  int32_t adjuster_site = -1;   // -1: not in the adjustment (refused)
  double distance_m = 0.0;      // driven from the first site
  TraverseFromSite odometry;    // the odometry chain's pose
  TraverseFromSite pose;        // the current estimate
  Mat6 covariance = Mat6::Zero();  // absolute (see the top)
  int8_t status = site_pose_t::STATUS_INVALID;
  int8_t registration = site_pose_t::REGISTRATION_NONE;
  int32_t tie_observations = 0;
};

// A camera of a site as its panorama's adjustment left it (site frame): what the site-pose adjuster carries.
struct RoverSiteCamera {
  InteriorOrientation io;
  Vec3 centre_m = Vec3::Zero();
  Mat3 m = Mat3::Identity();
  int32_t adjuster_camera = -1;  // added to the adjuster when a tie first needs it
};

// The cross-site matching of the last leg (into the site just finished).
struct RoverLegReport {
  DemRegistrationResult registration;
  CrossMatchCounts counts;
  int32_t ties = 0;               // matched (candidate, image) ties
  int32_t observations_added = 0; // into the adjuster
  int32_t observations_refused = 0;
  int32_t candidates_a = 0, kept_images_b = 0;
};
// The leg in a sentence (registration, ties, the matcher's refusals, observations), into `out`
// (NUL-terminated, at most `size` bytes).
void describeLeg(const RoverLegReport& leg, char* out, int32_t size);

struct RoverTraverseCounters {
  int32_t sites_adjusted = 0;
  int32_t sites_refused = 0;
  int32_t adjust_failures = 0;
  int32_t refused_by_cause[static_cast<int32_t>(Status::kCount)] = {};
  int32_t last_iterations = 0;
  double last_sigma0 = 0.0;
  int32_t last_window_sites = 0;
};

class RoverTraverse {
 public:
  void reset();
  // The announcement of the site whose pairs follow (decoded and checked: decodeSite).
  void announce(const site_t& site);
  // A pair's left image of the announced site (the matcher's frame, its network image and a-priori model).
  void keepImage(const ImageView& image, int32_t net_image, const CameraModel& apriori_model,
                 const PhotogrammetricCamera& apriori_camera);
  // The announced site's panorama has ended: the site enters the adjustment (with its ties to the site
  // before when `net` holds its adjusted panorama: its DEM, cameras and candidates are taken from it) and
  // the window is solved. Returns kOk, or why the site was refused (the record is still kept, STATUS_FAILED).
  [[nodiscard]] Status finishSite(const Network* net, const NetworkBuilder* builder);

  int32_t siteCount() const { return site_count_; }
  const RoverSiteRecord& site(int32_t k) const { return sites_[k]; }
  // The records of the last solve's window, oldest first: [firstPublished(), siteCount()).
  int32_t firstPublished() const { return first_published_; }
  const RoverTraverseCounters& counters() const { return counters_; }
  const RoverLegReport& lastLeg() const { return leg_; }
  const char* traverseName() const { return traverse_; }
  SitePoseAdjuster& adjuster() { return adjuster_; }

 private:
  Status refuse(Status cause);
  void solveWindow();
  // The site's record from its adjusted panorama: DEM, cameras, kept images' models, candidates.
  void capture(const Network& net, const NetworkBuilder& builder);
  // Registration and matching from the previous record into the current one; the ties into the adjuster.
  void tieLeg(int32_t record_b, int32_t site_a, int32_t site_b);
  int32_t cameraFor(int32_t record, int32_t site, int32_t image);

  SitePoseAdjuster adjuster_;
  RoverSiteRecord sites_[kMaxSites];
  int32_t site_count_ = 0;
  int32_t first_published_ = 0;
  char traverse_[kMaxRoverSiteChars + 1] = {0};
  // The pending announcement.
  bool pending_ = false;
  RoverSiteRecord pending_record_;
  char pending_from_[kMaxRoverSiteChars + 1] = {0};
  bool pending_has_leg_ = false;
  LegMeasurement pending_leg_;
  double pending_leg_distance_m_ = 0.0;
  TraverseFromSite pending_apriori_;
  RoverTraverseCounters counters_;

  // Cross-site matching: the previous site's record and the current one (they swap after each site).
  CrossSiteRecord records_[2];
  RoverSiteCamera cameras_[2][kMaxImages];
  int32_t camera_count_[2] = {0, 0};
  bool captured_[2] = {false, false};
  int32_t current_ = 0;
  CoarseDemRegistration registration_;
  CrossSiteMatcher matcher_;
  RoverCrossTie ties_[kMaxCrossSiteTiesPerLeg];
  RoverLegReport leg_;
};

// A pose's heading clockwise from north (degrees): atan2(r10, r00) of traverse_from_site.
double headingDegOf(const Mat3& rotation);

}  // namespace areomap
