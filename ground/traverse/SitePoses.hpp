// The sites' poses in the traverse frame and their sigmas (poses.csv), from the odometry chained from the
// first site with its covariance propagated leg by leg (a levelled pose: x, y, z, heading; each leg's
// displacement is measured in the previous site's frame, so a heading error there swings every later
// site about it).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/Traverse.hpp"

namespace areomap::traverse {

enum class PoseSource {
  kFirstSite,      // the traverse frame's origin
  kOdometry,       // the odometry chained (no cross-site tie fixed it)
  kCrossSiteTies,  // the multi-site adjustment: cross-site ties and the odometry (CrossSiteAdjustment.hpp)
};
const char* poseSourceName(PoseSource s);

struct SitePoseEstimate {
  std::string id;
  SitePose pose;
  Eigen::Matrix4d covariance = Eigen::Matrix4d::Zero();  // [x, y, z (m), heading (rad)]
  PoseSource source = PoseSource::kOdometry;
  double distance_m = 0.0;  // driven from the first site
  // The site frame's tilt in the traverse frame as the multi-site adjustment solved it (its rotation
  // exp([tilt]x) Rz(heading), the tilt about the traverse frame's x and y: the sites' levelling against
  // the first's), and its sigmas; zero where the odometry placed the site (levelled frames).
  Eigen::Vector2d tilt_rad = Eigen::Vector2d::Zero();
  Eigen::Vector2d tilt_sigma_rad = Eigen::Vector2d::Zero();
};

struct SitePoseSolution {
  std::vector<SitePoseEstimate> sites;  // in traverse order
  std::vector<std::string> notes;
};

// The a-priori poses (traverse.json) with the odometry's covariance chained along the legs.
SitePoseSolution odometryPoses(const Traverse& traverse);

// Position errors against truth: per site |p - p_true| (m); the RMS over the sites, and the RMS over the
// sites after the first of the error as a percentage of the distance driven to each. `include` (empty: every
// site) picks the sites the two RMS figures are taken over.
struct PositionErrors {
  std::vector<double> per_site_m;
  double rms_m = 0.0;
  double rms_pct = 0.0;
};
PositionErrors positionErrors(const std::vector<SitePose>& poses, const std::vector<double>& distance_m,
                              const TraverseTruth& truth, const std::vector<bool>& include = {});

// A site-frame camera model in the traverse frame: C' = R C + p, and A, H, V, O turned by R (H and V are
// linear in the frame's axes, so a rotation carries them); R, E and the image size unchanged.
CameraModel toTraverseFrame(const CameraModel& model, const SitePose& pose);

}  // namespace areomap::traverse
