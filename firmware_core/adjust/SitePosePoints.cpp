// The traverse adjuster's state and its start (SitePoseAdjuster.hpp): which observations count, the
// whitened cost at the current state, the placing of points from their rays, and the warm start's
// resection of new sites on the points their solved neighbours placed. No heap; every loop bounded.
#include "firmware_core/adjust/SitePoseAdjuster.hpp"

#include <algorithm>
#include <cmath>

#include "firmware_core/adjust/Network.hpp"  // rayOfIdealPixel
#include "firmware_core/camera/RayIntersection.hpp"

namespace areomap {

namespace {

// An observation whose point lies behind its camera is charged far above any real residual, so that an LM
// step that puts a point behind a camera is rejected.
constexpr double kSitePoseBehindCameraCost = 1e10;
// Resection of a new site (warm start): Gauss-Newton steps on its 6 unknowns, until its step is below this
// (metres at the nominal range), and the fewest observations it takes (3 points' worth).
constexpr int32_t kMaxResectionIterations = 10;
constexpr double kResectionStepTolerance_m = 1e-4;
constexpr double kResectionRange_m = 10.0;  // the range at which its rotation step is taken as metres
constexpr int32_t kMinResectionObservations = 6;

}  // namespace

template <typename C>
bool BasicSitePoseAdjuster<C>::usable(const CrossSiteObservation& o) const {
  return !o.rejected && inSolve(points_[o.point]);
}

template <typename C>
Status BasicSitePoseAdjuster<C>::observationError(int32_t o, Vec2& error) const {
  if (o < 0 || o >= observation_count_) return Status::kInvalidArgument;
  return observationRows(observations_[o], error, nullptr, nullptr);
}

template <typename C>
Status BasicSitePoseAdjuster<C>::observationRows(const CrossSiteObservation& o, Vec2& error, Mat2x6* d_pose,
                                                 Mat2x3* d_point) const {
  const SiteCamera& c = cameras_[o.camera];
  return crossSiteObservationRow(sites_[c.site].pose, c, points_[o.point].xyz_m, o.ideal_px, o.sigma_px,
                                 error, d_pose, d_point);
}

template <typename C>
double BasicSitePoseAdjuster<C>::cost(double* rms_px, int32_t* active) const {
  double total = 0.0;
  double pixel_sq = 0.0;
  int32_t n = 0;
  for (int32_t o = 0; o < observation_count_; ++o) {
    const CrossSiteObservation& ob = observations_[o];
    if (!usable(ob)) continue;
    Vec2 e;
    if (!ok(observationError(o, e))) {
      total += kSitePoseBehindCameraCost;
      continue;
    }
    const double sq = e.squaredNorm();
    const double norm = std::sqrt(sq);
    total += huber_ > 0.0 && norm > huber_ ? 2.0 * huber_ * norm - huber_ * huber_ : sq;
    pixel_sq += sq * ob.sigma_px * ob.sigma_px;
    ++n;
  }
  for (int32_t k = 1; k < site_count_; ++k) {
    if (!legActive(k)) continue;
    Vec6 e;
    odometryRows(sites_[k - 1].pose, sites_[k].pose, sites_[k].leg, e, nullptr, nullptr);
    total += e.squaredNorm();
  }
  if (rms_px != nullptr) *rms_px = n > 0 ? std::sqrt(pixel_sq / (2.0 * n)) : 0.0;
  if (active != nullptr) *active = n;
  return total;
}

template <typename C>
int32_t BasicSitePoseAdjuster<C>::raysInFront(const CrossSitePoint& pt, const Vec3& xyz) const {
  int32_t front = 0;
  for (int32_t k = 0; k < pt.obs_count; ++k) {
    const CrossSiteObservation& o = observations_[pt.obs[k]];
    if (o.rejected) continue;
    Vec3 centre;
    Mat3 camera_from_traverse;
    cameraInTraverse(sites_[cameras_[o.camera].site].pose, cameras_[o.camera], centre, camera_from_traverse);
    Vec3 d;
    d.noalias() = camera_from_traverse * (xyz - centre);
    front += d.z() < 0.0 ? 1 : 0;
  }
  return front;
}

template <typename C>
bool BasicSitePoseAdjuster<C>::placePoint(int32_t p) {
  CrossSitePoint& pt = points_[p];
  // Candidates: the intersection of the rays of each site with two or more (its cameras' relative EO is
  // exact, the single-site adjustment, so they meet where the point is in that site's frame), and of all
  // rays. Kept: the one in front of the most cameras (a gross error along a short stereo base can throw a
  // two-ray point behind the cameras), then the one of a site whose pose is better than odometry (a site
  // added to a solved traverse starts from points placed by its solved neighbours: the warm start), then
  // the most rays.
  int32_t site_rays[C::kSites] = {};
  int32_t total = 0;
  for (int32_t k = 0; k < pt.obs_count; ++k) {
    const CrossSiteObservation& o = observations_[pt.obs[k]];
    if (o.rejected) continue;
    ++site_rays[cameras_[o.camera].site];
    ++total;
  }
  if (total < 2) return false;
  Vec3 origins[kMaxObsPerCrossSitePoint];
  Vec3 directions[kMaxObsPerCrossSitePoint];
  int32_t best_front = -1, best_rays = 0, best_site = -1;
  bool best_good = false;
  Vec3 best_xyz = Vec3::Zero();
  // candidate site_count_: all rays.
  for (int32_t cand = 0; cand <= site_count_; ++cand) {
    const bool all = cand == site_count_;
    if (!all && site_rays[cand] < 2) continue;
    int32_t n = 0;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const CrossSiteObservation& o = observations_[pt.obs[k]];
      const SiteCamera& c = cameras_[o.camera];
      if (o.rejected || (!all && c.site != cand)) continue;
      Mat3 camera_from_traverse;
      cameraInTraverse(sites_[c.site].pose, c, origins[n], camera_from_traverse);
      directions[n] = rayOfIdealPixel(c.io, camera_from_traverse, o.ideal_px);
      ++n;
    }
    Vec3 xyz;
    if (!ok(intersectRays(origins, directions, n, xyz)) || !xyz.allFinite()) continue;
    const int32_t front = raysInFront(pt, xyz);
    const bool good = !all && goodPose(cand);
    const bool better =
        front > best_front ||
        (front == best_front && ((good && !best_good) || (good == best_good && n > best_rays)));
    if (!better) continue;
    best_front = front;
    best_good = good;
    best_rays = n;
    best_site = all ? -1 : cand;
    best_xyz = xyz;
  }
  if (best_front < 0) return false;
  pt.xyz_m = best_xyz;
  pt.placed = true;
  pt.placed_by = best_site;
  return true;
}

template <typename C>
void BasicSitePoseAdjuster<C>::preparePoints() {
  for (int32_t p = 0; p < point_count_; ++p) {
    CrossSitePoint& pt = points_[p];
    int32_t active = 0;
    for (int32_t k = 0; k < pt.obs_count; ++k) active += observations_[pt.obs[k]].rejected ? 0 : 1;
    if (active >= 2 && (!pt.placed || !pt.xyz_m.allFinite())) pt.placed = placePoint(p);
    pt.solvable = active >= 2 && pt.placed && pt.xyz_m.allFinite();
    pt.in_window = false;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const CrossSiteObservation& o = observations_[pt.obs[k]];
      pt.in_window = pt.in_window || (!o.rejected && freeSite(cameras_[o.camera].site));
    }
  }
}

template <typename C>
void BasicSitePoseAdjuster<C>::resectNewSites(SitePoseResult& result) {
  for (int32_t k = first_free_; k < site_count_; ++k) {
    if (sites_[k].solved || !(sites_[k - 1].solved || resected_[k - 1])) continue;
    const TraverseFromSite start = sites_[k].pose;
    if (!resect(k, result.resection_iterations)) {
      sites_[k].pose = start;  // no ties to solved sites: it stays where odometry put it
      continue;
    }
    resected_[k] = true;
    ++result.resected_sites;
    for (int32_t p = 0; p < point_count_; ++p) {
      CrossSitePoint& pt = points_[p];
      if (pt.placed && pt.placed_by == k && !placePoint(p)) pt.placed = false;
    }
  }
}

template <typename C>
bool BasicSitePoseAdjuster<C>::resect(int32_t site, int32_t& iterations) {
  for (int32_t it = 0; it < kMaxResectionIterations; ++it) {
    Mat6 n = Mat6::Zero();
    Vec6 g = Vec6::Zero();
    int32_t rows = 0;
    for (int32_t o = 0; o < observation_count_; ++o) {
      const CrossSiteObservation& ob = observations_[o];
      const SiteCamera& c = cameras_[ob.camera];
      const CrossSitePoint& pt = points_[ob.point];
      if (c.site != site || ob.rejected || !pt.placed || pt.placed_by < 0 || pt.placed_by == site ||
          !goodPose(pt.placed_by))
        continue;
      Vec2 e;
      Mat2x6 j;
      if (!ok(observationRows(ob, e, &j, nullptr))) continue;
      n.noalias() += j.transpose() * j;
      g.noalias() -= j.transpose() * e;
      ++rows;
    }
    if (rows < kMinResectionObservations) return false;
    Vec6 e;
    Mat6 ja, jb;
    odometryRows(sites_[site - 1].pose, sites_[site].pose, sites_[site].leg, e, &ja, &jb);
    n.noalias() += jb.transpose() * jb;
    g.noalias() -= jb.transpose() * e;
    const Eigen::LDLT<Mat6> ldlt(n);
    if (ldlt.info() != Eigen::Success) return false;
    const Vec6 step = ldlt.solve(g);
    if (!step.allFinite()) return false;
    applySiteUpdate(step, sites_[site].pose);
    ++iterations;
    if (step.head<3>().norm() + kResectionRange_m * step.tail<3>().norm() < kResectionStepTolerance_m) break;
  }
  return true;
}

template class BasicSitePoseAdjuster<TraverseCapacity<kMaxSites>>;
template class BasicSitePoseAdjuster<TraverseCapacity<kMaxGroundSites>>;

}  // namespace areomap
