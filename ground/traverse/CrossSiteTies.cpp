#include "ground/traverse/CrossSiteTies.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <memory>
#include <sstream>

#include <Eigen/Dense>

#include "firmware_core/match/ForstnerDetector.hpp"
#include "ground/cli/AtomicFile.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/traverse/CrossSiteAdjustment.hpp"

namespace areomap::traverse {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
constexpr int kGaussNewtonSteps = 6;  // per round of the geometric check
// The widest search about a prediction: its cost grows with the square of the radius (32 px at a grid step
// of one pixel is 65^2 NCCs of the template), and so do the chances of a false peak. A prediction more
// uncertain than that is not searched: in the first pass the second one, under the pose of the first one's
// ties, may take it; what is left then is B's height along a grazing source ray, a poor tie anyway.
constexpr double kMaxSearchRadiusPx = 32.0;

// An image that may observe a point, with the point in its site's frame.
struct Target {
  const SiteProducts* site = nullptr;
  const SiteImage* image = nullptr;
  bool in_a = false;
};

// Interest points of an image: the Förstner operator on the first pyramid level within its capacity,
// scaled back to full-resolution pixels.
std::vector<Eigen::Vector2d> interestPoints(const SiteImage& image, const CrossTieParams& params, int border,
                                            ForstnerWorkspace& workspace) {
  int level = 0;
  while (level + 1 < static_cast<int>(image.pyramid.size()) &&
         (image.pyramid[level].cols > kMaxImageWidth || image.pyramid[level].rows > kMaxImageHeight)) {
    ++level;
  }
  cv::Mat u8;
  image.pyramid[level].convertTo(u8, CV_8U);
  const ImageView view{u8.data, u8.cols, u8.rows, static_cast<int32_t>(u8.step)};
  ForstnerParams fp;
  fp.cell_px = params.cell_px > 0 ? params.cell_px >> level : std::max(16, u8.cols / 16);
  fp.cell_px = std::max(fp.cell_px, kMinSpreadingCellPx);
  fp.max_per_cell = std::min(params.per_cell, static_cast<int>(kMaxInterestPointsPerCell));
  fp.min_points = 1;
  fp.border_px = std::max(0, border >> level);
  std::vector<InterestPoint> found(kMaxInterestPoints);
  int32_t count = 0;
  (void)detectInterestPoints(view, fp, workspace, found.data(), kMaxInterestPoints,
                             count);  // kNoTexture: keep any
  std::vector<Eigen::Vector2d> out;
  const double scale = static_cast<double>(1 << level);
  for (int32_t k = 0; k < count; ++k) out.emplace_back(found[k].x_px * scale, found[k].y_px * scale);
  return out;
}

bool inside(const SiteImage& image, const Eigen::Vector2d& p, double margin) {
  return p.x() >= margin && p.y() >= margin && p.x() <= image.pyramid[0].cols - 1 - margin &&
         p.y() <= image.pyramid[0].rows - 1 - margin;
}

// Intersection of the ray through pixel `px` of `model` with a plane (point on it, normal).
bool rayOnPlane(const CameraModel& model, const Eigen::Vector2d& px, const Eigen::Vector3d& on_plane,
                const Eigen::Vector3d& normal, Eigen::Vector3d& hit) {
  Vec3 o, d;
  if (!ok(unproject(model, px, o, d))) return false;
  const double den = normal.dot(d);
  if (std::fabs(den) < 1e-9) return false;
  const double t = normal.dot(on_plane - o) / den;
  if (t <= 0.0) return false;
  hit = o + t * d;
  return true;
}

// A rigid map between the two sites' frames: from frame `from_a` (A when true, else B) into `to_a`.
Eigen::Vector3d moved(const RelativePose& a_from_b, bool from_a, bool to_a, const Eigen::Vector3d& p) {
  if (from_a == to_a) return p;
  return to_a ? a_from_b.toA(p) : a_from_b.toB(p);
}
Eigen::Vector3d turned(const RelativePose& a_from_b, bool from_a, bool to_a, const Eigen::Vector3d& d) {
  if (from_a == to_a) return d;
  return to_a ? Eigen::Vector3d(a_from_b.rotation() * d)
              : Eigen::Vector3d(a_from_b.rotation().transpose() * d);
}

// Most steps of the local ray-DEM search (each half a DEM cell): 4 m either side at 5 cm cells.
constexpr int kMaxSurfaceSteps = 160;

// One image's pixel to another's through a site's DEM: the pixel's ray meets the DEM near the tie's point
// (the first crossing from above, searched from the point's distance along the ray), projected into the
// other image. The DEM, the cameras and the tie's point may each be in either site's frame.
class DemSurface : public PatchSurface {
 public:
  DemSurface(const CameraModel& from, bool from_a, const CameraModel& to, bool to_a, const DemGrid& dem,
             bool dem_a, const RelativePose& a_from_b, const Eigen::Vector3d& point_in_dem)
      : from_(from),
        to_(to),
        dem_(dem),
        pose_(a_from_b),
        point_(point_in_dem),
        from_a_(from_a),
        to_a_(to_a),
        dem_a_(dem_a) {}

  bool map(const Eigen::Vector2d& i_px, Eigen::Vector2d& j_px) const override {
    Vec3 o3, d3;
    if (!ok(unproject(from_, i_px, o3, d3))) return false;
    const Eigen::Vector3d o = moved(pose_, from_a_, dem_a_, o3);
    const Eigen::Vector3d d = turned(pose_, from_a_, dem_a_, d3);
    const double horizontal = d.head<2>().norm();
    const double step = 0.5 * dem_.cell_m / std::max(horizontal, 0.1);
    auto above = [&](double t, bool& valid) {
      const Eigen::Vector3d p = o + t * d;
      const double e = demElevation(dem_, p.x(), p.y());
      valid = std::isfinite(e);
      return -p.z() - e;
    };
    double t = (point_ - o).dot(d);
    bool valid = false;
    double h = above(t, valid);
    if (!valid) return false;
    // Back to where the ray is above the surface, then on to the first crossing.
    int k = 0;
    for (; k < kMaxSurfaceSteps && h <= 0.0; ++k) {
      t -= step;
      h = above(t, valid);
      if (!valid || t <= 0.0) return false;
    }
    double lo = t, hi = t;
    for (k = 0; k < kMaxSurfaceSteps; ++k) {
      hi = lo + step;
      h = above(hi, valid);
      if (!valid) return false;
      if (h <= 0.0) break;
      lo = hi;
    }
    if (k == kMaxSurfaceSteps) return false;
    for (int it = 0; it < 20; ++it) {
      const double mid = 0.5 * (lo + hi);
      (above(mid, valid) > 0.0 ? lo : hi) = mid;
    }
    const Eigen::Vector3d hit = moved(pose_, dem_a_, to_a_, o + 0.5 * (lo + hi) * d);
    Vec2 px;
    if (!ok(project(to_, hit, px))) return false;
    j_px = px;
    return true;
  }

 private:
  const CameraModel& from_;
  const CameraModel& to_;
  const DemGrid& dem_;
  RelativePose pose_;
  Eigen::Vector3d point_;
  bool from_a_, to_a_, dem_a_;
};

struct GeoObservation {
  int tie = 0;
  int obs = 0;
  const CameraModel* model = nullptr;
  bool in_a = false;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  bool active = true;
};

// Triangulates a point (B's frame) from the rays of its active observations: least squares of the
// perpendicular distances.
bool triangulate(const std::vector<GeoObservation>& obs, const std::vector<int>& of_tie,
                 const RelativePose& pose, Eigen::Vector3d& x) {
  Eigen::Matrix3d n = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  int rays = 0;
  const RelativePose b_from_a = pose.inverse();
  for (int k : of_tie) {
    if (!obs[k].active) continue;
    Vec3 o, d;
    if (!ok(unproject(*obs[k].model, obs[k].pixel, o, d))) continue;
    Eigen::Vector3d ob = o, db = d;
    if (obs[k].in_a) {
      ob = b_from_a.toA(o);  // the inverse maps A's frame into B's
      db = b_from_a.rotation() * d;
    }
    const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - db * db.transpose();
    n += p;
    rhs += p * ob;
    ++rays;
  }
  if (rays < 2) return false;
  x = n.ldlt().solve(rhs);
  return x.allFinite();
}

}  // namespace

const char* crossTieStatusName(CrossTieStatus status) {
  switch (status) {
    case CrossTieStatus::kOk:
      return "ok";
    case CrossTieStatus::kNoOverlap:
      return "no_overlap";
    case CrossTieStatus::kRegistrationFailed:
      return "registration_failed";
    case CrossTieStatus::kTooFewTies:
      return "too_few_ties";
  }
  return "unknown";
}

int CrossTieResult::observationCount() const {
  int n = 0;
  for (const CrossTie& t : ties) n += static_cast<int>(t.observations.size());
  return n;
}

namespace {

void countRefusal(PatchResult result, CrossTieCounts& counts) {
  switch (result) {
    case PatchResult::kLowNcc:
      ++counts.low_ncc;
      break;
    case PatchResult::kAmbiguous:
      ++counts.ambiguous;
      break;
    case PatchResult::kEdgePeak:
      ++counts.edge_peak;
      break;
    case PatchResult::kLsmDiverged:
      ++counts.lsm_diverged;
      break;
    case PatchResult::kOk:
      break;
    case PatchResult::kOutside:
    case PatchResult::kFlat:
      ++counts.patch_outside;
      break;
  }
}

// Steps 2 and 3: candidates from B's images matched into A's (and B's other) images under `pose`.
void matchTies(const SiteProducts& a, const SiteProducts& b, const RelativePose& pose,
               const Eigen::Matrix4d& pose_cov, const CrossTieParams& params, int64_t first_point, int stride,
               CrossTieResult& out) {
  out.ties.clear();
  // 2 + 3: candidates from B's images, matched into A's (and B's other) images.
  auto workspace = std::make_unique<ForstnerWorkspace>();
  const int border = params.patch.half + 2;
  const double sin_incidence = std::sin(params.min_incidence_deg * kDegToRad);
  const double max_scale = params.max_scale_ratio > 0.0
                               ? params.max_scale_ratio
                               : std::sqrt(2.0) * static_cast<double>(1 << (kPyramidLevels - 1));
  int64_t next_point = first_point;
  for (const SiteImage& source : b.images) {
    const std::vector<Eigen::Vector2d> points = interestPoints(source, params, border, *workspace);
    out.counts.interest_points += static_cast<int>(points.size());
    for (std::size_t n = 0; n < points.size(); n += static_cast<std::size_t>(stride)) {
      const Eigen::Vector2d& q = points[n];
      Vec3 o, d;
      double t = 0.0;
      if (!ok(unproject(source.model, q, o, d)) || !castRayOnDem(b.dem, o, d, params.max_range_m, t))
        continue;
      const Eigen::Vector3d pb = o + t * d;
      const Eigen::Vector3d pa = pose.toA(pb);
      const double ea = demElevation(a.dem, pa.x(), pa.y());
      if (!std::isfinite(ea) || std::fabs(ea + pa.z()) > params.max_height_gap_m + 0.01 * pa.head<2>().norm())
        continue;
      Eigen::Vector3d normal, on_plane;
      if (!demPlane(b.dem, pb, params.plane_radius_m, normal, on_plane)) continue;
      on_plane = pb;  // the plane through the cast point, with the DEM's local slope
      if (std::fabs(normal.dot(Eigen::Vector3d(d))) < sin_incidence) continue;
      ++out.counts.on_both_dems;
      // The footprint map of the source: ground points of q and of q + 2 px along x and y.
      const double step = 2.0;
      Eigen::Vector3d gx, gy;
      if (!rayOnPlane(source.model, q + Eigen::Vector2d(step, 0), on_plane, normal, gx) ||
          !rayOnPlane(source.model, q + Eigen::Vector2d(0, step), on_plane, normal, gy)) {
        continue;
      }
      // The surface the patches are warped through: the DEM of the site that knows the point better (the
      // smaller dem_sigma there; B's without sigmas).
      const DemGrid* surface_dem = &b.dem;
      bool surface_in_a = false;
      if (a.dem_sigma && b.dem_sigma) {
        const double sa = demElevation(*a.dem_sigma, pa.x(), pa.y());
        const double sb = demElevation(*b.dem_sigma, pb.x(), pb.y());
        if (std::isfinite(sa) && (!std::isfinite(sb) || sa < sb)) {
          surface_dem = &a.dem;
          surface_in_a = true;
        }
      }
      const Eigen::Vector3d surface_point = surface_in_a ? pa : pb;
      // B's height uncertainty at the point and the source ray's incidence on the ground.
      double source_dh_m = 0.0;
      if (b.dem_sigma) {
        const double sb = demElevation(*b.dem_sigma, pb.x(), pb.y());
        source_dh_m = std::isfinite(sb) ? sb : 0.0;
      }
      const double source_sin = std::max(std::fabs(normal.dot(Eigen::Vector3d(d))), sin_incidence);
      CrossTie tie;
      tie.point = next_point;
      tie.b_m = pb;
      tie.observations.push_back({next_point, b.id, source.stem, q, true, 1.0});
      bool any_a = false;
      for (int side = 0; side < 2; ++side) {
        const SiteProducts& site = side == 0 ? a : b;
        const bool in_a = side == 0;
        const Eigen::Vector3d p = in_a ? pa : pb;
        auto bump = [&](int CrossTieCounts::*field) {
          ++(out.counts.*field);
          if (in_a) ++(out.counts_in_a.*field);
        };
        for (const SiteImage& target : site.images) {
          if (&target == &source) continue;
          Vec2 pj;
          if (!ok(project(target.model, p, pj)) || !inside(target, pj, 2.0)) {
            bump(&CrossTieCounts::outside_image);
            continue;
          }
          const Eigen::Vector3d ray = p - target.model.c;
          const double range = ray.norm();
          if (range > params.max_range_m) {
            bump(&CrossTieCounts::beyond_range);
            continue;
          }
          if (std::fabs(normal.dot(ray / range)) < sin_incidence) {
            bump(&CrossTieCounts::grazing);
            continue;
          }
          double hit = 0.0;
          if (castRayOnDem(site.dem, target.model.c, ray / range, range + 1.0, hit) &&
              hit < range * (1.0 - params.occlusion_tolerance) - 0.05) {
            bump(&CrossTieCounts::occluded);
            continue;
          }
          Vec2 px, py;
          const Eigen::Vector3d gxs = in_a ? pose.toA(gx) : gx, gys = in_a ? pose.toA(gy) : gy;
          if (!ok(project(target.model, gxs, px)) || !ok(project(target.model, gys, py))) continue;
          Eigen::Matrix2d map;
          map.col(0) = (px - pj) / step;
          map.col(1) = (py - pj) / step;
          const double scale = std::sqrt(std::fabs(map.determinant()));
          if (!(scale <= max_scale && scale >= 1.0 / max_scale)) {
            bump(&CrossTieCounts::scale_gate);
            continue;
          }
          bump(&CrossTieCounts::predicted);
          const DemSurface forward(source.model, false, target.model, in_a, *surface_dem, surface_in_a, pose,
                                   surface_point);
          const DemSurface backward(target.model, in_a, source.model, false, *surface_dem, surface_in_a, pose,
                                    surface_point);
          const bool use_surface = params.surface_warp;
          PatchParams patch = params.patch;
          if (params.derived_radius) {
            // The prediction's uncertainty in this image: the pose's (for A's images) and B's DEM height
            // along the source ray (the cast point slides along it by dh / sin(incidence)).
            Mat2x3 dp;
            Vec2 unused;
            if (!ok(project(target.model, p, unused, &dp))) continue;
            const Eigen::Matrix3d r = in_a ? pose.rotation() : Eigen::Matrix3d::Identity();
            Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
            if (in_a) {
              const Eigen::Vector3d rb = r * pb;
              Eigen::Matrix<double, 2, 4> jc;
              jc.leftCols<3>() = dp;
              jc.col(3) = dp * Eigen::Vector3d(-rb.y(), rb.x(), 0.0);
              cov = jc * pose_cov * jc.transpose();
            }
            const Eigen::Vector2d slide = dp * (r * Eigen::Vector3d(d)) * source_dh_m / source_sin;
            cov += slide * slide.transpose();
            const double sigma_px =
                std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cov).eigenvalues()[1]);
            patch.radius_px = params.search_sigmas * sigma_px + params.min_radius_px;
            if (!(patch.radius_px <= kMaxSearchRadiusPx)) {
              bump(&CrossTieCounts::too_uncertain);
              continue;
            }
          }
          const PatchMatch m = matchWarpedPatch(source.pyramid, q, target.pyramid, pj, map, patch,
                                                use_surface ? &forward : nullptr);
          if (m.result != PatchResult::kOk) {
            countRefusal(m.result, out.counts);
            if (in_a) countRefusal(m.result, out.counts_in_a);
            continue;
          }
          bump(&CrossTieCounts::matched);
          // The back-match starts from the source point itself: the matcher's own pull-in is enough.
          PatchParams back_patch = params.patch;
          if (params.derived_radius) back_patch.radius_px = params.min_radius_px;
          const PatchMatch back = matchWarpedPatch(target.pyramid, m.j_px, source.pyramid, q, map.inverse(),
                                                   back_patch, use_surface ? &backward : nullptr);
          const double tolerance = params.lr_tolerance_px * std::max(1.0, 1.0 / scale);
          if (back.result != PatchResult::kOk || (back.j_px - q).norm() > tolerance) {
            bump(&CrossTieCounts::back_failed);
            continue;
          }
          bump(&CrossTieCounts::back_matched);
          tie.observations.push_back({next_point, site.id, target.stem, m.j_px, false, m.ncc_final});
          any_a = any_a || in_a;
        }
      }
      if (!any_a) continue;
      out.ties.push_back(std::move(tie));
      ++next_point;
    }
  }
}

// Step 4: the geometric check; `pose` is the prior (and the start), the result goes into `out`.
void checkTies(const SiteProducts& a, const SiteProducts& b, const RelativePose& pose,
               const CrossTieParams& params, CrossTieResult& out) {
  // 4: geometric check, a bundle of the pose and the points with trimming.
  std::vector<GeoObservation> geo;
  std::vector<std::vector<int>> of_tie(out.ties.size());
  for (std::size_t i = 0; i < out.ties.size(); ++i) {
    for (std::size_t k = 0; k < out.ties[i].observations.size(); ++k) {
      const CrossTieObservation& ob = out.ties[i].observations[k];
      const bool in_a = ob.site == a.id;
      const SiteProducts& site = in_a ? a : b;
      of_tie[i].push_back(static_cast<int>(geo.size()));
      geo.push_back({static_cast<int>(i), static_cast<int>(k), &site.images[site.indexOf(ob.image)].model,
                     in_a, ob.pixel_px, true});
    }
  }
  std::vector<bool> tie_alive(out.ties.size(), true);
  std::vector<Eigen::Vector3d> x(out.ties.size());
  RelativePose current = pose;
  const Eigen::Vector4d prior_sigma(params.prior_sigma_m, params.prior_sigma_m, params.prior_sigma_m,
                                    params.prior_sigma_deg * kDegToRad);
  Eigen::Matrix4d reduced = Eigen::Matrix4d::Identity();
  double rms = 0.0;
  for (int round = 0; round < params.max_check_rounds; ++round) {
    for (std::size_t i = 0; i < out.ties.size(); ++i) {
      if (tie_alive[i] && !triangulate(geo, of_tie[i], current, x[i])) tie_alive[i] = false;
    }
    for (int it = 0; it < kGaussNewtonSteps; ++it) {
      reduced.setZero();
      Eigen::Vector4d g = Eigen::Vector4d::Zero();
      const Eigen::Vector4d offset(current.translation_m.x() - pose.translation_m.x(),
                                   current.translation_m.y() - pose.translation_m.y(),
                                   current.translation_m.z() - pose.translation_m.z(),
                                   current.heading_rad - pose.heading_rad);
      for (int c = 0; c < 4; ++c) {
        reduced(c, c) += 1.0 / (prior_sigma[c] * prior_sigma[c]);
        g[c] += offset[c] / (prior_sigma[c] * prior_sigma[c]);
      }
      std::vector<Eigen::Matrix3d> hxx(out.ties.size());
      std::vector<Eigen::Matrix<double, 3, 4>> hxc(out.ties.size());
      std::vector<Eigen::Vector3d> gx(out.ties.size());
      const Eigen::Matrix3d r = current.rotation();
      for (std::size_t i = 0; i < out.ties.size(); ++i) {
        if (!tie_alive[i]) continue;
        hxx[i].setZero();
        hxc[i].setZero();
        gx[i].setZero();
        Eigen::Matrix4d hcc = Eigen::Matrix4d::Zero();
        Eigen::Vector4d gc = Eigen::Vector4d::Zero();
        for (int k : of_tie[i]) {
          if (!geo[k].active) continue;
          Vec2 pixel;
          Mat2x3 dp;
          const Eigen::Vector3d rx = r * x[i];
          const Eigen::Vector3d p = geo[k].in_a ? Eigen::Vector3d(rx + current.translation_m) : x[i];
          if (!ok(project(*geo[k].model, p, pixel, &dp))) continue;
          const Eigen::Vector2d res = pixel - geo[k].pixel;
          Eigen::Matrix<double, 2, 3> jx = dp;
          Eigen::Matrix<double, 2, 4> jc = Eigen::Matrix<double, 2, 4>::Zero();
          if (geo[k].in_a) {
            jx = dp * r;
            jc.leftCols<3>() = dp;
            jc.col(3) = dp * Eigen::Vector3d(-rx.y(), rx.x(), 0.0);
          }
          hxx[i].noalias() += jx.transpose() * jx;
          hxc[i].noalias() += jx.transpose() * jc;
          gx[i].noalias() += jx.transpose() * res;
          hcc.noalias() += jc.transpose() * jc;
          gc.noalias() += jc.transpose() * res;
        }
        hxx[i] += 1e-9 * Eigen::Matrix3d::Identity();
        const Eigen::Matrix3d inv = hxx[i].inverse();
        reduced += hcc - hxc[i].transpose() * inv * hxc[i];
        g += gc - hxc[i].transpose() * inv * gx[i];
      }
      const Eigen::Vector4d dc = -reduced.ldlt().solve(g);
      if (!dc.allFinite()) break;
      current.translation_m += dc.head<3>();
      current.heading_rad += dc[3];
      for (std::size_t i = 0; i < out.ties.size(); ++i) {
        if (tie_alive[i]) x[i] += -hxx[i].inverse() * (gx[i] + hxc[i] * dc);
      }
    }
    // Residuals, robust sigma, rejection.
    std::vector<double> norms;
    std::vector<double> res_of(geo.size(), 0.0);
    const Eigen::Matrix3d r = current.rotation();
    for (std::size_t k = 0; k < geo.size(); ++k) {
      if (!geo[k].active || !tie_alive[geo[k].tie]) continue;
      const Eigen::Vector3d& xi = x[geo[k].tie];
      const Eigen::Vector3d p = geo[k].in_a ? Eigen::Vector3d(r * xi + current.translation_m) : xi;
      Vec2 pixel;
      res_of[k] = ok(project(*geo[k].model, p, pixel)) ? (pixel - geo[k].pixel).norm() : 1e9;
      norms.push_back(res_of[k]);
    }
    if (norms.empty()) break;
    double sq = 0.0;
    for (double v : norms) sq += v * v;
    rms = std::sqrt(sq / static_cast<double>(norms.size()));
    std::vector<double> sorted = norms;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    // The norm of a 2-D residual: its median is 1.1774 sigma for Gaussian components.
    const double sigma = sorted[sorted.size() / 2] / 1.1774;
    const double limit = std::max(params.residual_floor_px, params.residual_sigmas * sigma);
    int dropped = 0;
    for (std::size_t i = 0; i < out.ties.size(); ++i) {
      if (!tie_alive[i]) continue;
      // Per tie, drop its worst observation beyond the limit.
      int worst = -1;
      for (int k : of_tie[i]) {
        if (geo[k].active && res_of[k] > limit && (worst < 0 || res_of[k] > res_of[worst])) worst = k;
      }
      if (worst < 0) continue;
      geo[worst].active = false;
      ++dropped;
      ++out.counts.rejected_observations;
      bool has_a = false, has_b = false;
      for (int k : of_tie[i]) {
        if (!geo[k].active) continue;
        (geo[k].in_a ? has_a : has_b) = true;
      }
      const bool source_lost = out.ties[i].observations[geo[worst].obs].source;
      if (source_lost || !has_a || !has_b) {
        tie_alive[i] = false;
        ++out.counts.rejected_ties;
      }
    }
    if (dropped == 0) break;
  }
  const Eigen::Matrix4d cov = reduced.inverse() * std::max(rms * rms / 2.0, 1e-6);
  out.a_from_b_covariance = cov;
  for (int c = 0; c < 4; ++c) out.a_from_b_sigma[c] = std::sqrt(std::max(0.0, cov(c, c)));
  out.a_from_b = current;
  out.rms_px = rms;

  // Parallax discipline against the DEMs: the point triangulated from all the views must lie on both sites'
  // surfaces within their height sigmas (a match that slid along the other site's rays moves it off).
  for (std::size_t i = 0; i < out.ties.size(); ++i) {
    if (!tie_alive[i]) continue;
    const Eigen::Vector3d xa = current.toA(x[i]);
    bool on_both = true;
    for (const auto& [site, p] : {std::pair<const SiteProducts*, Eigen::Vector3d>{&b, x[i]}, {&a, xa}}) {
      const double e = demElevation(site->dem, p.x(), p.y());
      double sigma = 0.0;
      if (site->dem_sigma) {
        sigma = demElevation(*site->dem_sigma, p.x(), p.y());
        if (!std::isfinite(sigma)) sigma = 0.0;
      }
      const double limit = std::max(params.height_floor_m, params.height_sigmas * sigma);
      if (!std::isfinite(e) || std::fabs(e + p.z()) > limit) on_both = false;
    }
    if (!on_both) {
      tie_alive[i] = false;
      ++out.counts.off_dem_ties;
    }
  }

  // Kept ties with their kept observations.
  std::vector<CrossTie> kept;
  for (std::size_t i = 0; i < out.ties.size(); ++i) {
    if (!tie_alive[i]) continue;
    CrossTie t = out.ties[i];
    t.b_m = x[i];
    t.observations.clear();
    for (int k : of_tie[i]) {
      if (geo[k].active) t.observations.push_back(out.ties[i].observations[geo[k].obs]);
    }
    kept.push_back(std::move(t));
  }
  out.ties = std::move(kept);
}

}  // namespace

CrossTieResult findCrossSiteTies(const SiteProducts& a, const SiteProducts& b, const RelativePose& apriori,
                                 const CrossTieParams& params, int64_t first_point) {
  CrossTieResult out;
  out.site_a = a.id;
  out.site_b = b.id;
  out.registration = registerDems(a, b, apriori, params.registration);
  out.a_from_b = out.registration.a_from_b;
  if (out.registration.status != RegistrationStatus::kOk) {
    out.status = out.registration.status == RegistrationStatus::kNoOverlap
                     ? CrossTieStatus::kNoOverlap
                     : CrossTieStatus::kRegistrationFailed;
    out.message = out.registration.message;
    return out;
  }
  // A first pass under the registered pose (every first_pass_stride-th interest point, a wide search: the
  // registration's error is 10-30 cm on ground-pass DEMs, ten pixels and more at navcam scale), a second
  // one, every point, under the pose of the first pass's ties with a narrow search.
  const RelativePose registered = out.registration.a_from_b;
  CrossTieParams wide = params;
  wide.patch.radius_px = params.second_pass ? params.first_radius_px : params.patch.radius_px;
  matchTies(a, b, registered, out.registration.covariance, wide, first_point,
            params.second_pass ? params.first_pass_stride : 1, out);
  out.counts.ties_before_check = static_cast<int>(out.ties.size());
  checkTies(a, b, registered, params, out);
  out.first_pass_ties = static_cast<int>(out.ties.size());
  out.first_pass_counts = out.counts;
  if (params.second_pass && static_cast<int>(out.ties.size()) >= params.min_ties) {
    const RelativePose first = out.a_from_b;
    const Eigen::Matrix4d first_cov = out.a_from_b_covariance;
    CrossTieParams narrow = params;
    narrow.patch.radius_px = params.second_radius_px;
    out.counts = CrossTieCounts{};
    out.counts_in_a = CrossTieCounts{};
    matchTies(a, b, first, first_cov, narrow, first_point, 1, out);
    out.counts.ties_before_check = static_cast<int>(out.ties.size());
    checkTies(a, b, first, narrow, out);
  }
  if (static_cast<int>(out.ties.size()) < params.min_ties) {
    out.status = CrossTieStatus::kTooFewTies;
    out.message = "sites " + a.id + " and " + b.id + ": " + std::to_string(out.ties.size()) +
                  " cross-site ties (at least " + std::to_string(params.min_ties) + " wanted)";
  } else {
    out.status = CrossTieStatus::kOk;
  }
  return out;
}

std::vector<CrossSiteTie> crossSiteObservations(const std::vector<CrossTie>& ties) {
  std::vector<CrossSiteTie> flat;
  for (const CrossTie& t : ties) {
    for (const CrossTieObservation& o : t.observations)
      flat.push_back({o.point, o.site, o.image, o.pixel_px});
  }
  return flat;
}

}  // namespace areomap::traverse
