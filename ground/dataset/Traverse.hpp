// A multi-site traverse: a folder with `traverse.json` naming the sites in driving order, each a
// complete single-site dataset (panorama.json, ...) under `sites/<id>/`, and for a synthetic traverse the
// truth poses in `truth/traverse.json`. Schema: docs/traverse.md "traverse.json".
//
// Frames. Every site's dataset is in that site's own site frame (MER: +X north, +Y east, +Z down, metres),
// levelled, with its origin at the site: the frame is attached to the rover, so the site's a-priori models,
// rig and (synthetic) truth files are all in it and each site is mapped alone exactly as a single-site
// dataset. The traverse frame is the first site's frame. A site pose places a site frame in the traverse
// frame: p_traverse = Rz(heading) p_site + position, heading clockwise from north (+X towards +Y, a
// rotation about +Z down). The a-priori pose is the odometry's dead-reckoned estimate of that placement
// (traverse.json); the true pose is where the frame really lies (truth/traverse.json). The first site's
// a-priori and true poses are both the identity.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ground/dataset/DatasetError.hpp"

namespace areomap {

// A levelled pose of a site frame in the traverse frame.
struct SitePose {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // the site origin in the traverse frame
  double heading_rad = 0.0;                              // clockwise from north, about +Z (down)

  // traverse_from_site rotation Rz(heading).
  Eigen::Matrix3d rotation() const;
  Eigen::Vector3d toTraverse(const Eigen::Vector3d& site_m) const;
  Eigen::Vector3d toSite(const Eigen::Vector3d& traverse_m) const;
  bool isIdentity() const { return heading_rad == 0.0 && position_m.isZero(0.0); }
};

// The rover's attitude at a site (optional; a simulated traverse on sloped ground writes it): its body tilted
// in the levelled site frame, site_from_rover = Ry(pitch) Rx(roll), rover x forward (the site's +X at yaw 0),
// y right, z down; pitch positive nose up, roll positive right side down. The rover's rig stands on that
// body: the a-priori models of a site are levelled by the a-priori attitude (traverse.json, an IMU's, with
// its sigma), the truth models by the true one (truth/traverse.json).
struct RoverAttitude {
  double roll_rad = 0.0;
  double pitch_rad = 0.0;
  Eigen::Matrix3d rotation() const;  // site_from_rover
};

// The rover's odometry over one leg, from the previous site to this one, as the rover measured it: the
// displacement in the previous site's frame and the change of heading, with their standard deviations.
struct OdometryLeg {
  std::string from;                                   // the previous site's id
  Eigen::Vector3d delta_m = Eigen::Vector3d::Zero();  // this site's origin in the previous site's frame
  double delta_heading_rad = 0.0;                     // heading here minus heading there
  double distance_m = 0.0;                            // distance driven over the leg
  Eigen::Vector3d sigma_m = Eigen::Vector3d::Zero();  // per axis of delta_m (previous site's frame)
  double sigma_heading_rad = 0.0;
};

// What the rover did at a site: a whole panorama, or a traversing stop on the way (a few stereo pairs
// looking forward, docs/traverse.md "Traversing stops"). Both are mapped alike; a stop ties the sites
// around it.
enum class SiteKind { kPanorama, kStop };
const char* siteKindName(SiteKind kind);  // "panorama", "stop"

struct TraverseSite {
  std::string id;                       // "site01"
  std::string path;                     // as written, relative to the traverse folder ("sites/site01")
  std::string dir;                      // resolved: the traverse folder / path
  SiteKind kind = SiteKind::kPanorama;  // traverse.json "kind" (optional, default "panorama")
  SitePose apriori;
  std::optional<OdometryLeg> odometry;    // absent for the first site
  std::optional<RoverAttitude> attitude;  // a priori, traverse.json "attitude" (optional)
  double attitude_sigma_rad = 0.0;        // its sigma per axis (roll, pitch); set with `attitude`
};

struct Traverse {
  int version = 1;
  std::string root;  // the traverse folder as given to readTraverse
  std::string name;
  double drift_fraction = 0.0;           // horizontal position sigma per axis / leg distance
  double vertical_drift_fraction = 0.0;  // vertical sigma / leg distance
  double heading_sigma_rad = 0.0;        // heading sigma per leg
  std::vector<TraverseSite> sites;       // in driving order

  double distanceDrivenM() const;  // sum of the legs' distances
  // The index of a site id, or -1.
  int indexOf(const std::string& id) const;
};

// The truth of a synthetic traverse: each site's true pose in the traverse frame, in site order.
struct TraverseTruth {
  std::vector<std::string> ids;
  std::vector<SitePose> poses;
  // The true attitude per site ("attitude", optional): empty, or one per site (nullopt where absent).
  std::vector<std::optional<RoverAttitude>> attitudes;
  double max_slope_deg = 0.0;  // "terrain": {"max_slope_deg"} of a simulated sloped terrain (0: absent)
};

constexpr const char* kTraverseFileName = "traverse.json";
constexpr const char* kTraverseTruthFile = "truth/traverse.json";
constexpr int kTraverseVersion = 1;

// Reads DIR/traverse.json (DIR may also name the file itself). Throws DatasetError naming the file and the
// field: version, unique safe ids and paths, at least one site, the first site's pose the identity and no
// odometry there, every later site's odometry from the site before it, positive sigmas and distances.
Traverse readTraverse(const std::string& dir);
// Throws DatasetError naming traverse.json and sites[i].path when a site's folder holds no panorama.json.
void checkTraverseSites(const Traverse& traverse);
// Writes DIR/traverse.json (creating DIR); throws DatasetError when it cannot.
void writeTraverse(const Traverse& traverse, const std::string& dir);

// Reads DIR/truth/traverse.json when it exists (std::nullopt when absent); `traverse` names the sites it
// must hold, in the same order. Throws DatasetError naming the file and field on a bad file.
std::optional<TraverseTruth> readTraverseTruth(const std::string& dir, const Traverse& traverse);
void writeTraverseTruth(const TraverseTruth& truth, const std::string& dir);

}  // namespace areomap
