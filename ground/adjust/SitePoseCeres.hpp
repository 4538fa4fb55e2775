// The reference solver of the multi-site (traverse) adjustment: the problem of
// firmware_core/adjust/SitePoseAdjuster.hpp written again, independently, for Ceres, so that the firmware
// solver can be compared with it on the same problem (tests/ground/adjust: ground_site_pose_bench,
// SitePoseCeresTest).
//
// The same problem: the same unknowns (per free site its 6-DOF pose, per cross-site point its position in
// the traverse frame), the same rows (an ideal-pixel observation through the collinearity of a camera that
// its site carries rigidly, C = p + Q C_s, M = M_s Q^T, whitened by sigma_px; an odometry leg into every
// site whose leg the firmware counts — a free site or the site after a free one — as the 6 whitened rows
// [Q_a^T (p_b - p_a) - d, log(Q_ab_measured^T Q_a^T Q_b)], SitePoseRows.hpp), the same datum (site 0 and
// the sites before first_free_site held), the same points in the solve (>= 2 rays not rejected, at least
// one of them from a free site), and optionally the same Huber loss on an observation's whitened 2-vector
// (rho(s) = 2 c sqrt(s) - c^2 beyond c^2: Ceres' HuberLoss(c) is the firmware's). Written with automatic
// derivatives, not with the firmware's analytic Jacobians: a site's rotation is a unit quaternion on
// Ceres' quaternion manifold (the left update Q' = exp(dtheta) Q, the firmware's), its position a 3-vector.
// Costs are reported in the firmware's convention: the sum of whitened squares (Ceres minimises half of it).
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "firmware_core/adjust/Network.hpp"  // rayOfIdealPixel
#include "firmware_core/adjust/SitePoseAdjuster.hpp"
#include "firmware_core/camera/RayIntersection.hpp"

namespace areomap::ground {

struct SitePoseObservation {
  int32_t point = -1;
  int32_t camera = -1;
  Vec2 ideal_px = Vec2::Zero();
  double sigma_px = 0.3;
  bool rejected = false;  // left out of the solve
};

// A traverse adjustment problem and its current state (the start before a solve, the solution after).
struct SitePoseProblem {
  std::vector<TraverseFromSite> poses;  // per site
  std::vector<LegMeasurement> legs;     // [k]: from site k-1 to site k (legs[0] unused)
  std::vector<SiteCamera> cameras;
  std::vector<Vec3> points;  // traverse frame
  std::vector<bool> placed;  // per point: has a position (else left out)
  std::vector<SitePoseObservation> observations;
  int32_t first_free_site = 1;  // the sites before it (and site 0) are held
};

struct SitePoseCeresOptions {
  double huber_sigma = 0.0;  // > 0: the Huber loss with this threshold on every observation
  bool dense_schur = true;   // DENSE_SCHUR (the poses' reduced system is small and dense), else SPARSE_SCHUR
  int32_t max_iterations = 100;
  // Ceres' relative tolerances, tight: the minimum to rounding, so that the firmware's own stop is judged.
  double function_tolerance = 1e-14;
  double gradient_tolerance = 1e-14;
  double parameter_tolerance = 1e-12;
};

struct SitePoseCeresResult {
  bool converged = false;
  // Levenberg-Marquardt steps, accepted and rejected (the firmware's iterations: one linearisation each;
  // Ceres' iteration 0, the start, not counted).
  int32_t iterations = 0;
  int32_t observations = 0;  // in the solve
  int32_t points = 0;        // in the solve
  int32_t free_sites = 0;
  double initial_cost = 0.0;  // sum of whitened squares (Huber where asked), the firmware's convention
  double cost = 0.0;
  double seconds = 0.0;     // building the Ceres problem and solving it
  std::string termination;  // Ceres' termination type (CONVERGENCE, NO_CONVERGENCE: the iteration bound)
  std::string message;
};

// Solves the problem from its state with Ceres and writes the solution back into it.
SitePoseCeresResult solveSitePosesCeres(SitePoseProblem& problem, const SitePoseCeresOptions& options);

// The cost of the problem at its state computed by the firmware's rows (SitePoseRows.hpp
// crossSiteObservationRow, odometryRows) over the observations and legs that solveSitePosesCeres uses: the
// cross-check of the two formulations. rms_px: the image residuals' RMS per coordinate.
double sitePoseRowsCost(const SitePoseProblem& problem, double huber_sigma, double* rms_px = nullptr);

// The problem an adjuster holds. poses: the sites' a-priori poses (`apriori`) or their current ones; points:
// with `apriori`, each placed as the adjuster's first placement did (the intersection of the rays of the
// site that placed it, CrossSitePoint::placed_by, or of all its rays, at the a-priori poses: the firmware's
// start after an adjust() from the a-priori state of points added unplaced), else at their current
// positions. Rejection flags are copied when `rejections`, else cleared.
template <typename Adjuster>
SitePoseProblem sitePoseProblemOf(const Adjuster& adjuster, int32_t first_free_site, bool apriori,
                                  bool rejections) {
  SitePoseProblem p;
  p.first_free_site = first_free_site;
  for (int32_t k = 0; k < adjuster.siteCount(); ++k) {
    p.poses.push_back(apriori ? adjuster.site(k).apriori : adjuster.site(k).pose);
    p.legs.push_back(adjuster.site(k).leg);
  }
  for (int32_t c = 0; c < adjuster.cameraCount(); ++c) p.cameras.push_back(adjuster.camera(c));
  for (int32_t o = 0; o < adjuster.observationCount(); ++o) {
    const CrossSiteObservation& a = adjuster.observation(o);
    p.observations.push_back({a.point, a.camera, a.ideal_px, a.sigma_px, rejections && a.rejected});
  }
  for (int32_t i = 0; i < adjuster.pointCount(); ++i) {
    const CrossSitePoint& pt = adjuster.point(i);
    p.points.push_back(pt.xyz_m);
    p.placed.push_back(pt.placed);
    if (!apriori || !pt.placed) continue;
    Vec3 origins[kMaxObsPerCrossSitePoint];
    Vec3 directions[kMaxObsPerCrossSitePoint];
    int32_t n = 0;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const CrossSiteObservation& o = adjuster.observation(pt.obs[k]);
      const SiteCamera& cam = adjuster.camera(o.camera);
      if (pt.placed_by >= 0 && cam.site != pt.placed_by) continue;
      Mat3 camera_from_traverse;
      cameraInTraverse(p.poses[cam.site], cam, origins[n], camera_from_traverse);
      directions[n] = rayOfIdealPixel(cam.io, camera_from_traverse, o.ideal_px);
      ++n;
    }
    Vec3 xyz;
    const bool placed = ok(intersectRays(origins, directions, n, xyz)) && xyz.allFinite();
    p.points.back() = placed ? xyz : Vec3::Zero();
    p.placed.back() = placed;
  }
  return p;
}

// The largest differences between a problem's state and an adjuster's: site positions (m) and rotations
// (rad, the angle of Q_problem Q_adjuster^T), and the positions of the points in the adjuster's last solve.
struct SitePoseDifference {
  double position_m = 0.0;
  double rotation_rad = 0.0;
  double point_m = 0.0;
};

template <typename Adjuster>
SitePoseDifference sitePoseDifference(const Adjuster& adjuster, const SitePoseProblem& p) {
  SitePoseDifference d;
  for (int32_t k = 0; k < adjuster.siteCount(); ++k) {
    const TraverseFromSite& a = adjuster.site(k).pose;
    const Mat3 r = p.poses[k].rotation * a.rotation.transpose();
    d.position_m = std::max(d.position_m, (p.poses[k].position_m - a.position_m).norm());
    d.rotation_rad = std::max(d.rotation_rad, Eigen::AngleAxisd(r).angle());
  }
  for (int32_t i = 0; i < adjuster.pointCount(); ++i) {
    const CrossSitePoint& pt = adjuster.point(i);
    if (pt.solvable && pt.in_window) d.point_m = std::max(d.point_m, (p.points[i] - pt.xyz_m).norm());
  }
  return d;
}

}  // namespace areomap::ground
