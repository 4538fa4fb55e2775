// The geometry of a simulated panorama, without images: the mast head and its plan, the true and a-priori
// CAHVOR models of every image, the rig constants (Eq. 3, Eq. 4), and true 3-D check points on the terrain
// with their true image coordinates in every image that sees them (visibility by ray casting, so rocks and
// relief occlude). Fast enough for in-process tests of the adjustment (no rendering).
//
// Frames: site (x north, y east, z down). The head frame at pan 0, tilt 0 is x forward (north), y right
// (east), z down; the head turns by R_head = Rz(pan) * Ry(tilt) about the gimbal centre (pan clockwise
// from north, tilt up positive). Camera frames are the photogrammetric ones (rows of M = [H'; -V'; -A]).
// The a-priori pointing error is a pan/tilt error of the whole head per pair (like the mast's encoders),
// so the a-priori models satisfy Eq. 3 and Eq. 4 with the same rig constants as the true ones.
//
// One site of a traverse (ground/sim/TraverseSim.hpp): the geometry is made in that site's own frame (the
// rover at its origin, as above) and `terrain_from_site` places it on the shared terrain (the site's true
// pose); check points are found and images rendered on the terrain, and everything written is in the site
// frame. On sloped ground (a RoverStance) the rover stands tilted on its base: the mast rises mast_m from
// the base along the rover's up axis, the head turns in the rover's frame, the true models follow the true
// attitude and the a-priori ones (and the rig's gimbal centre in panorama.json) the a-priori attitude, so the
// a-priori panorama is the true one turned about the base by the attitude error, besides the pointing errors.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/sim/SimConfig.hpp"
#include "ground/sim/Terrain.hpp"
#include "ground/sim/TraversePlan.hpp"

namespace areomap::sim {

struct SimCamera {
  std::string stem;     // "p007_L"
  CameraModel truth;    // CAHVOR, with width/height
  CameraModel apriori;  // pointing-derived model (head pan/tilt error)
  Eigen::Matrix3d site_to_camera = Eigen::Matrix3d::Identity();  // true M = [H'; -V'; -A]
};

struct SimPair {
  int id = 0;
  int sol = 1;
  int tier = 0;
  double pan_deg = 0.0;
  double tilt_deg = 0.0;
  double pan_error_rad = 0.0;      // a-priori minus true head pan
  double tilt_error_rad = 0.0;     // a-priori minus true head tilt
  double pointing_error_px = 0.0;  // the requested image-centre error of this pair
  SimCamera left;
  std::optional<SimCamera> right;
};

struct SimGeometry {
  SimConfig config;
  Eigen::Vector3d gimbal_m = Eigen::Vector3d::Zero();          // site frame, true
  Eigen::Vector3d apriori_gimbal_m = Eigen::Vector3d::Zero();  // a priori (panorama.json): the same, levelled
  Eigen::Vector3d left_offset_m = Eigen::Vector3d::Zero();     // M_L (C_L - X_G), Eq. 3
  Eigen::Vector3d right_offset_m = Eigen::Vector3d::Zero();    // M_R (C_R - X_G), Eq. 3
  Eigen::Vector3d base_m = Eigen::Vector3d::Zero();            // M_L (C_R - C_L), Eq. 4
  std::vector<SimPair> pairs;
  std::vector<CheckPoint> points;              // true 3-D check points on the surface
  std::vector<ImageObservation> observations;  // their true (distorted) pixels, image = stem
  // A site of a traverse: where the site frame lies on the terrain (its true pose), the half side of its
  // truth/dem.tif (site frame, about the site origin) and the dataset's name. Absent: the site frame is the
  // terrain's own and truth/dem.tif is the whole terrain (Terrain::dem).
  std::optional<SitePose> terrain_from_site;
  std::optional<RoverStance> stance;  // sloped ground (with terrain_from_site): the rover's attitude and base
  double dem_half_extent_m = 0.0;
  std::string name;  // empty: "sim-<preset>-<seed>"

  // Every camera in pair order (left, then right).
  std::vector<const SimCamera*> cameras() const;
  // A site-frame model in the terrain's frame (itself when the site frame is the terrain's).
  CameraModel inTerrain(const CameraModel& model) const;
  // panorama.json content for a dataset folder `root`: images/<stem>.png, models/<stem>.cahvor.
  Dataset dataset(const std::string& root) const;
};

// Makes the plan, the models and the check points. Builds the terrain when none is given (check points and
// visibility need it); validatePlan() first (throws cli::UsageError for an impossible plan).
SimGeometry makeGeometry(const SimConfig& config);
SimGeometry makeGeometry(const SimConfig& config, const Terrain& terrain,
                         const std::optional<SitePose>& terrain_from_site = std::nullopt,
                         const std::optional<RoverStance>& stance = std::nullopt);

// The CAHVOR model of a camera with centre `centre_m`, rotation `site_to_camera` (rows H', -V', -A),
// principal distance `f_px`, principal point (x0, y0) and distortion (O tilted from A, R = 0 rho1 rho2).
CameraModel makeCahvor(const Eigen::Vector3d& centre_m, const Eigen::Matrix3d& site_to_camera, double f_px,
                       double x0_px, double y0_px, double o_tilt_deg, double rho1, double rho2, int width,
                       int height);

// Is a site point seen by a camera (in front, inside the image with `margin_px`, not occluded by the
// terrain, not at grazing incidence)? On success `pixel` holds its true (distorted) image coordinates.
bool pointVisible(const Terrain& terrain, const CameraModel& model, const Eigen::Vector3d& point_m,
                  double margin_px, Vec2& pixel);

// How many true cameras see ground beyond the terrain grid (rendered as a flat far plane that truth/dem.tif
// does not cover): 0 when the grid covers all that the cameras see.
int camerasSeeingBeyondTerrain(const SimGeometry& geometry, const Terrain& terrain);

}  // namespace areomap::sim
