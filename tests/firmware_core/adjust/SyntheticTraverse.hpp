// Test-only generator of a multi-site traverse with truth for SitePoseAdjuster: a random winding
// path of sites 10-30 m apart, each with a ring of stereo pairs on a mast (EO in the site frame, exact: the
// single-site adjustment's result), ground points between neighbouring sites seen by the cameras of every
// site within range, observations = true ideal pixels + Gaussian noise (+ optional gross errors of
// 10-50 px). Odometry: every leg's measured relative pose is truth + noise of the configured sigmas (5 % of
// the leg horizontally, 2 deg heading); the a-priori poses are the chain of the measured legs from site 0.
#pragma once

#include <cstdint>
#include <vector>

#include "firmware_core/adjust/SitePoseAdjuster.hpp"

namespace areomap::test {

struct TraverseConfig {
  int32_t sites = 8;
  double min_step_m = 10.0;
  double max_step_m = 30.0;
  double max_turn_deg = 35.0;  // heading change between sites
  double max_tilt_deg = 3.0;   // site frame tilt against the traverse frame
  int32_t azimuths = 10;       // stereo pairs of a site's ring
  double elevation_deg = 20.0;
  int32_t width = 1024;
  int32_t height = 1024;
  double f_px = 1236.0;
  double baseline_m = 0.2;
  double mast_height_m = 1.5;
  int32_t points_per_leg = 40;  // ground points between each two neighbouring sites
  double max_range_m = 25.0;    // a site's cameras see points up to this range
  double noise_px = 0.3;
  double outlier_fraction = 0.0;
  // Odometry sigmas: per horizontal axis of the previous site's frame (a fraction of the leg), vertical,
  // heading (about the site's z) and tilt.
  double odo_horizontal_fraction = 0.05;
  double odo_vertical_fraction = 0.01;
  double odo_heading_deg = 2.0;
  double odo_tilt_deg = 0.25;
  bool odometry_noise = true;  // false: the measured legs are exact (the a-priori chain still drifts)
  int32_t isolated_site = -1;  // a site whose cameras see no point (no cross-site ties)
  uint32_t seed = 1;
};

struct TraverseObservation {
  int32_t point = -1;
  int32_t site = -1;
  int32_t camera = -1;  // index into TraversePlan::cameras
  Vec2 ideal_px = Vec2::Zero();
  double sigma_px = 0.3;
  bool outlier = false;
};

struct TraversePlan {
  std::vector<TraverseFromSite> truth;    // per site
  std::vector<TraverseFromSite> apriori;  // odometry chain
  std::vector<LegMeasurement> legs;       // [k]: from site k-1 to k (legs[0] unused)
  std::vector<SiteCamera> cameras;        // all sites' cameras (site set)
  std::vector<Vec3> points;               // truth, traverse frame
  std::vector<TraverseObservation> observations;
};

TraversePlan makeTraversePlan(const TraverseConfig& config);

// Where a plan's items went in an adjuster (index in the adjuster, -1 until loaded).
struct TraverseLoad {
  std::vector<int32_t> camera;
  std::vector<int32_t> point;
  std::vector<int32_t> observation;
};

// Adds sites [first, last) of the plan with their cameras, and every observation made from them (points
// added on first sight, unplaced). Site 0 is the datum at its true pose; site k starts at `apriori` of the
// plan when `apriori_start`, else at the previous site's current pose composed with the leg (warm start).
// Clears the adjuster when first == 0. Returns false when the adjuster refused anything.
// Instantiated for SitePoseAdjuster and GroundSitePoseAdjuster.
template <typename Adjuster>
bool loadTraverse(const TraversePlan& plan, int32_t first, int32_t last, bool apriori_start,
                  Adjuster& adjuster, TraverseLoad& load);

// Pose error [p_est - p_true, log(Q_est Q_true^T)] (traverse frame), the form of SiteState::covariance.
Vec6 poseError(const TraverseFromSite& estimate, const TraverseFromSite& truth);

}  // namespace areomap::test
