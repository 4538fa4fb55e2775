// The rows of the multi-site (traverse) adjustment (SitePoseAdjuster.hpp): a site's pose,
// a camera carried rigidly by it, the collinearity of a cross-site tie observation and the odometry leg
// between consecutive sites, each with analytic Jacobians over the local pose update.
//
// Frames (DESIGN.md: every site frame is MER-like, +X north, +Y east, +Z down, metres):
// - The TRAVERSE frame is the site frame of the traverse's first site (site 0, the datum).
// - A site's pose is traverse_from_site: position p (the site frame's origin in the traverse frame, m) and
//   rotation Q (site-frame vectors -> traverse-frame vectors): X_traverse = p + Q X_site.
// - A camera of a site keeps its single-site EO in the SITE frame: centre C_s and rotation M_s (site ->
//   camera, Photogrammetric.hpp). In the traverse frame it is
//       C = p + Q C_s,   M = M_s Q^T   (traverse -> camera).
// - The local pose update [dp (3, traverse frame, m), dtheta (3, traverse frame, rad)] is
//       p' = p + dp,   Q' = exp([dtheta]x) Q,
//   i.e. the site turns about its own origin, the axis given in the traverse frame. For the camera that
//   is the update of Constraints.hpp applyCameraUpdate with dC = dp - [Q C_s]x dtheta and
//   delta = -M dtheta (camera frame): M' = M_s Q^T exp(-[dtheta]x) = exp(-[M dtheta]x) M.
//
// Odometry leg from site a to site b (consecutive): the measured pose of b in a's site frame,
//       d = Q_a^T (p_b - p_a)  (m, site a frame),   Q_ab = Q_a^T Q_b  (site b -> site a),
// with a sigma per component: 3 of position along a's axes (north, east, down) and 3 of rotation (rad,
// about b's axes: x, y the tilt, z the heading change). Error rows, whitened:
//       e_pos = (Q_a^T (p_b - p_a) - d) / sigma_pos,   e_rot = log(Q_ab_measured^T Q_a^T Q_b) / sigma_rot.
// Full 6-DOF, not heading-only: a rover's IMU gives tilt well (a small tilt sigma), wheel odometry gives
// heading and distance poorly (large sigmas); the caller sets the sigmas, and a tilt sigma as large as
// the heading one makes the leg a plain relative-pose measurement.
//
// Every row here is an ERROR e(x) = (predicted - measured) / sigma with J = de/dx: the normal equations
// are (J^T J) dx = -J^T e, the cost sum e^2.
#pragma once

#include <cstdint>

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/Status.hpp"
#include "firmware_core/camera/Photogrammetric.hpp"

namespace areomap {

// A site's full 6-DOF pose, traverse_from_site: X_traverse = position_m + rotation X_site. (Not the
// levelled, heading-only SitePose of ground/dataset/Traverse.hpp that traverse.json carries: that one is
// rotation = Rz(heading_rad).)
struct TraverseFromSite {
  Vec3 position_m = Vec3::Zero();
  Mat3 rotation = Mat3::Identity();
};

// A camera of a site, its EO in the site frame fixed (the single-site adjustment's result).
struct SiteCamera {
  int32_t site = -1;
  InteriorOrientation io;
  Vec3 centre_in_site_m = Vec3::Zero();
  Mat3 m_site = Mat3::Identity();  // site -> camera
};

// The measured pose of site `to` in the site frame of site `to - 1`, with its sigmas (see the top). From
// traverse.json's OdometryLeg (ground/dataset/Traverse.hpp): delta_position_m = delta_m, delta_rotation =
// Rz(delta_heading_rad), sigma_position_m = sigma_m, sigma_rotation_rad = (tilt, tilt, sigma_heading_rad)
// with the tilt sigma of the rover's levelling.
struct LegMeasurement {
  Vec3 delta_position_m = Vec3::Zero();    // in the frame of the previous site
  Mat3 delta_rotation = Mat3::Identity();  // site `to` -> previous site
  Vec3 sigma_position_m = Vec3::Constant(1.0);
  Vec3 sigma_rotation_rad = Vec3::Constant(0.035);
};

// The camera in the traverse frame: C = p + Q C_s, M = M_s Q^T.
void cameraInTraverse(const TraverseFromSite& pose, const SiteCamera& camera, Vec3& centre_m,
                      Mat3& camera_from_traverse);

// Applies the local update [dp, dtheta] to a pose (rotation re-orthonormalised).
void applySiteUpdate(const Vec6& update, TraverseFromSite& pose);

// The pose `b` relative to `a` in a's frame: d = Q_a^T (p_b - p_a), Q_ab = Q_a^T Q_b.
void relativePose(const TraverseFromSite& a, const TraverseFromSite& b, Vec3& delta_position_m,
                  Mat3& delta_rotation);

// Inverse of the right Jacobian of SO(3) at phi: log(exp(phi) exp(eps)) = phi + jrInverse(phi) eps +
// O(eps^2).
Mat3 rightJacobianInverse(const Vec3& phi);

// Whitened error (predicted - observed) / sigma_px of an ideal-pixel observation of `point` (traverse frame)
// by `camera` of a site at `pose`, and its Jacobians over the site's [dp, dtheta] (2x6) and the point
// (2x3). kBehindCamera when the point is not in front of the camera.
[[nodiscard]] Status crossSiteObservationRow(const TraverseFromSite& pose, const SiteCamera& camera,
                                             const Vec3& point_m, const Vec2& ideal_px, double sigma_px,
                                             Vec2& error, Mat2x6* d_pose, Mat2x3* d_point);

// Whitened error rows [position 3, rotation 3] of an odometry leg from pose `a` to pose `b`, and their
// Jacobians over a's and b's [dp, dtheta] (exact: the rotation rows use the right-Jacobian inverse).
void odometryRows(const TraverseFromSite& a, const TraverseFromSite& b, const LegMeasurement& leg,
                  Vec6& error, Mat6* d_a, Mat6* d_b);

}  // namespace areomap
