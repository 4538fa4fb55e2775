// The poses of a simulated multi-site traverse: the true path, the rover's odometry over each
// leg and the a-priori site poses dead-reckoned from it. No terrain and no images: the heights come from a
// ground-elevation function, so the statistics can be tested on thousands of seeds in milliseconds.
//
// True path: site 1 at the origin heading north (the traverse frame is site 1's frame); before each leg
// the rover turns by a heading change uniform in +-max_turn_deg, then drives straight for a distance
// uniform in [leg_min_m, leg_max_m] and stops facing the way it drove. Every site origin stands at the same
// height above the ground under it as site 1's (z_k = e(0, 0) - e(x_k, y_k), Z down, e the elevation up),
// so every site has the same rig in its own frame.
// Odometry: each leg's measured displacement (in the previous site's frame) and heading change are the
// true ones plus independent Gaussian errors: sigma drift_fraction * d per horizontal axis,
// vertical_drift_fraction * d vertically (d the leg's distance) and heading_drift_deg in heading. The
// a-priori poses are these measurements chained from site 1 (a random walk: errors accumulate).
// Traversing stops (stop_spacing_m > 0): on the way, the rover stops every stop_spacing_m or less (the leg
// cut into equal parts, none longer) and takes a few stereo pairs looking forward (ground/sim/TraverseSim).
// A stop is a site of the plan like any other, kind kStop, id "stopNN-M" (the M-th stop after site NN),
// on the straight line of its leg, facing the way the rover drives; the odometry then runs from stop to
// stop, each part with its own errors (sigmas by its own distance). The panorama sites' true path does not
// depend on the stops.
// Sloped ground (max_slope_deg > 0; ground/sim/SimConfig.hpp has the terrain's swells): each site's rover
// stands on its wheels. The plane fitted (least squares) to the ground's elevation at the six wheel contacts
// (kWheelContacts, in the rover frame = the site frame's axes) gives its true attitude (roll, pitch) and the
// base it stands on (the plane's elevation under the rover's centre); the mast rises from that base along
// the rover's tilted up axis. The a-priori attitude is an IMU's: the true roll and pitch plus independent
// Gaussian errors of tilt_sigma_deg per site (levelling at rest: no random walk). With max_slope_deg 0
// there is no attitude at all (no stances): every site levelled as before, tilt_sigma_deg unused.
// Every random number is a hash of the seed and the leg (ground/sim/Noise.hpp): deterministic and portable;
// without stops a plan is the same as before stops existed.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "ground/dataset/Traverse.hpp"

namespace areomap::sim {

struct TraverseSettings {
  int sites = 5;
  double leg_min_m = 10.0;
  double leg_max_m = 30.0;
  double max_turn_deg = 40.0;
  double drift_fraction = 0.05;           // --odometry-drift-pct / 100
  double vertical_drift_fraction = 0.01;  // --vertical-drift-pct / 100
  double heading_drift_deg = 2.0;         // --heading-drift-deg
  double stop_spacing_m = 0.0;            // --stop-spacing-m: a traversing stop at least this often; 0 none
  double max_slope_deg = 0.0;             // --max-slope-deg: the terrain's swells (0: level world, as before)
  double tilt_sigma_deg = 0.2;            // --tilt-sigma-deg: IMU roll and pitch error (sloped ground only)
};

// The rover's six wheel contacts (x forward, y right, metres from its centre): a MER-sized rocker-bogie,
// 1.4 m wheelbase, 1.2 m track, inside the rock-free footprint of the terrain (ground/sim/Terrain.cpp).
constexpr int kWheelCount = 6;
constexpr double kWheelContacts[kWheelCount][2] = {{0.7, -0.6}, {0.7, 0.6},   {0.0, -0.6},
                                                   {0.0, 0.6},  {-0.7, -0.6}, {-0.7, 0.6}};

// How a rover stands at a site on sloped ground.
struct RoverStance {
  RoverAttitude truth;            // from the plane under its wheels
  RoverAttitude apriori;          // its IMU's: truth plus the tilt error
  double base_elevation_m = 0.0;  // the plane's elevation (up, traverse frame) under the rover's centre
};

struct TraversePlan {
  std::vector<std::string> ids;      // "site01", "stop01-1", "site02", ... in driving order
  std::vector<SiteKind> kinds;       // kPanorama or kStop, per site
  std::vector<SitePose> truth;       // true poses in the traverse frame
  std::vector<SitePose> apriori;     // dead-reckoned from the odometry
  std::vector<OdometryLeg> legs;     // legs[k - 1]: from site k - 1 to site k (0-based sites)
  std::vector<RoverStance> stances;  // per site on sloped ground; empty on a level world
  double distanceM() const;
};

// Up to 99 sites (two-digit ids).
constexpr int kMaxTraverseSites = 99;

// The id of the panorama site at 0-based `index`: "site01" for 0.
std::string traverseSiteId(int index);
// The id of the `stop`-th (1-based) traversing stop after panorama site `index`: "stop01-1" for 0, 1.
std::string traverseStopId(int index, int stop);

// Checks the settings; throws cli::UsageError naming the option.
void validateTraverse(const TraverseSettings& settings);

// The plan for `seed`. `ground_elevation_up_m(x, y)` gives the ground's elevation (up) at a traverse point;
// empty: flat ground (every z 0). The horizontal path does not depend on it.
TraversePlan planTraverse(const TraverseSettings& settings, uint64_t seed,
                          const std::function<double(double, double)>& ground_elevation_up_m = {});

// The rover at `pose` standing on the ground `ground_elevation_up_m` (traverse frame): the true attitude and
// base from the plane through its wheel contacts (kWheelContacts); `apriori` is left equal to the truth.
RoverStance standOnGround(const SitePose& pose,
                          const std::function<double(double, double)>& ground_elevation_up_m);

// The pose reached from `from` by the displacement `delta_m` (in from's frame) and heading change.
SitePose composePose(const SitePose& from, const Eigen::Vector3d& delta_m, double delta_heading_rad);

}  // namespace areomap::sim
