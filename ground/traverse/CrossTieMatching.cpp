// Steps 2 and 3 of the cross-site ties (CrossTieSteps.hpp): candidates from B's images cast through B's
// DEM, predicted into every image that may see them through the gates (in the image, in range, not grazing,
// not occluded, footprints of like scale, a search radius within the widest) and matched there by NCC on
// the DEM-warped grid and back.
#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include <Eigen/Dense>

#include "firmware_core/base/Angles.hpp"
#include "firmware_core/match/ForstnerDetector.hpp"
#include "ground/cli/Parallel.hpp"
#include "ground/traverse/CrossTieSteps.hpp"

namespace areomap::traverse {

namespace {

// The widest search about a prediction: its cost grows with the square of the radius (32 px at a grid step
// of one pixel is 65^2 NCCs of the template), and so do the chances of a false peak. A prediction more
// uncertain than that is not searched: in the first pass the second one, under the pose of the first one's
// ties, may take it; what is left then is B's height along a grazing source ray, a poor tie anyway.
constexpr double kMaxSearchRadiusPx = 32.0;

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
// Most regula falsi steps on the bracket of the crossing, and the height above the surface (m) taken as
// on it: far below what a pixel sees.
constexpr int kCrossingSteps = 12;
constexpr double kCrossingTolerance = 1e-7;

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
    double lo = t, hi = t, h_lo = h, h_hi = h;
    for (k = 0; k < kMaxSurfaceSteps; ++k) {
      hi = lo + step;
      h_hi = above(hi, valid);
      if (!valid) return false;
      if (h_hi <= 0.0) break;
      lo = hi;
      h_lo = h_hi;
    }
    if (k == kMaxSurfaceSteps) return false;
    // The crossing within the bracket by regula falsi with the Illinois step (the end kept twice has its
    // height halved), which keeps the bracket and converges in a few steps on the piecewise bilinear
    // surface, until the ray is within kCrossingTolerance of it.
    double crossing = 0.5 * (lo + hi);
    int kept = 0;  // +1: lo kept last, -1: hi kept last
    for (int it = 0; it < kCrossingSteps; ++it) {
      if (!(h_lo - h_hi > 0.0)) break;
      crossing = lo + (hi - lo) * h_lo / (h_lo - h_hi);
      const double h_at = above(crossing, valid);
      if (!valid || std::fabs(h_at) < kCrossingTolerance) break;
      if (h_at > 0.0) {
        lo = crossing;
        h_lo = h_at;
        if (kept == -1) h_hi *= 0.5;
        kept = -1;
      } else {
        hi = crossing;
        h_hi = h_at;
        if (kept == 1) h_lo *= 0.5;
        kept = 1;
      }
    }
    const Eigen::Vector3d hit = moved(pose_, dem_a_, to_a_, o + crossing * d);
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

// A candidate tie: an interest point of B's source image cast onto B's DEM, with what each target image's
// prediction and patch search need.
struct Candidate {
  Eigen::Vector2d q = Eigen::Vector2d::Zero();  // the interest point (source pixels)
  Vec3 d = Vec3::Zero();                        // the source ray's direction (B's frame)
  Eigen::Vector3d pb = Eigen::Vector3d::Zero(),
                  pa = Eigen::Vector3d::Zero();      // the cast point, B's and A's frame
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // B's local ground plane there
  // The footprint map of the source: ground points of q + step along x and along y (B's frame).
  Eigen::Vector3d gx = Eigen::Vector3d::Zero(), gy = Eigen::Vector3d::Zero();
  // The surface the patches are warped through and the point on it (in that surface's frame).
  const DemGrid* surface_dem = nullptr;
  bool surface_in_a = false;
  Eigen::Vector3d surface_point = Eigen::Vector3d::Zero();
  double source_dh_m = 0.0;   // B's height uncertainty at the point
  double source_sin = 0.0;    // the source ray's incidence on the ground (at least the gate's)
  bool on_both_dems = false;  // cast onto B's DEM, found on A's, on a plane steep enough to the ray
};

constexpr double kFootprintStepPx = 2.0;

// Step 2 for one interest point: cast onto B's DEM, found on A's (within max_height_gap_m), on a plane the
// source ray meets steeply enough. False when any of that fails.
bool castCandidate(const SiteProducts& a, const SiteProducts& b, const DemCeiling& b_ceiling,
                   const RelativePose& pose, const CrossTieParams& params, const SiteImage& source,
                   const Eigen::Vector2d& q, double sin_incidence, Candidate& c) {
  Vec3 o, d;
  double t = 0.0;
  if (!ok(unproject(source.model, q, o, d)) || !castRayOnDem(b.dem, b_ceiling, o, d, params.max_range_m, t))
    return false;
  const Eigen::Vector3d pb = o + t * d;
  const Eigen::Vector3d pa = pose.toA(pb);
  const double ea = demElevation(a.dem, pa.x(), pa.y());
  if (!std::isfinite(ea) || std::fabs(ea + pa.z()) > params.max_height_gap_m + 0.01 * pa.head<2>().norm())
    return false;
  Eigen::Vector3d normal, on_plane;
  if (!demPlane(b.dem, pb, params.plane_radius_m, normal, on_plane)) return false;
  on_plane = pb;  // the plane through the cast point, with the DEM's local slope
  if (std::fabs(normal.dot(Eigen::Vector3d(d))) < sin_incidence) return false;
  c.q = q;
  c.d = d;
  c.pb = pb;
  c.pa = pa;
  c.normal = normal;
  c.on_both_dems = true;
  if (!rayOnPlane(source.model, q + Eigen::Vector2d(kFootprintStepPx, 0), on_plane, normal, c.gx) ||
      !rayOnPlane(source.model, q + Eigen::Vector2d(0, kFootprintStepPx), on_plane, normal, c.gy)) {
    return false;
  }
  // The surface the patches are warped through: the DEM of the site that knows the point better (the
  // smaller dem_sigma there; B's without sigmas).
  c.surface_dem = &b.dem;
  c.surface_in_a = false;
  if (a.dem_sigma && b.dem_sigma) {
    const double sa = demElevation(*a.dem_sigma, pa.x(), pa.y());
    const double sb = demElevation(*b.dem_sigma, pb.x(), pb.y());
    if (std::isfinite(sa) && (!std::isfinite(sb) || sa < sb)) {
      c.surface_dem = &a.dem;
      c.surface_in_a = true;
    }
  }
  c.surface_point = c.surface_in_a ? pa : pb;
  // B's height uncertainty at the point and the source ray's incidence on the ground.
  c.source_dh_m = 0.0;
  if (b.dem_sigma) {
    const double sb = demElevation(*b.dem_sigma, pb.x(), pb.y());
    c.source_dh_m = std::isfinite(sb) ? sb : 0.0;
  }
  c.source_sin = std::max(std::fabs(normal.dot(Eigen::Vector3d(d))), sin_incidence);
  return true;
}

// The search radius of a prediction from its uncertainty in the target image: the pose's (for A's images)
// and B's DEM height along the source ray (the cast point slides along it by dh / sin(incidence)). False
// when the point does not project.
bool derivedRadius(const SiteImage& target, const Eigen::Vector3d& p, bool in_a, const RelativePose& pose,
                   const PoseMatrix& pose_cov, const Candidate& c, const CrossTieParams& params,
                   double& radius_px) {
  Mat2x3 dp;
  Vec2 unused;
  if (!ok(project(target.model, p, unused, &dp))) return false;
  const Eigen::Matrix3d r = in_a ? pose.rotation() : Eigen::Matrix3d::Identity();
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  if (in_a) {
    const Eigen::Vector3d rb = r * c.pb;
    Eigen::Matrix<double, 2, 6> jc;
    jc.leftCols<3>() = dp;
    jc.col(3) = dp * Eigen::Vector3d(-rb.y(), rb.x(), 0.0);
    jc.rightCols<2>() = dp * turnJacobian(rb).leftCols<2>();
    cov = jc * pose_cov * jc.transpose();
  }
  const Eigen::Vector2d slide = dp * (r * Eigen::Vector3d(c.d)) * c.source_dh_m / c.source_sin;
  cov += slide * slide.transpose();
  const double sigma_px = std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cov).eigenvalues()[1]);
  radius_px = params.search_sigmas * sigma_px + params.min_radius_px;
  return true;
}

// The largest singular value of a 2x2 map: how far it carries a unit step in the worst direction.
double largestStretch(const Eigen::Matrix2d& m) {
  const double f2 = m.squaredNorm(), det = m.determinant();
  return std::sqrt(0.5 * (f2 + std::sqrt(std::max(0.0, f2 * f2 - 4.0 * det * det))));
}

// What one candidate's predictions refused, matched and back-matched: over every target image and over A's
// alone.
struct Tally {
  CrossTieCounts all, in_a;
};

// What the candidate search of one pass shares.
struct Pass {
  const SiteProducts& a;
  const SiteProducts& b;
  const RelativePose& pose;
  const PoseMatrix& pose_cov;
  const CrossTieParams& params;
  double sin_incidence = 0.0;
  double max_scale = 0.0;
  DemCeiling a_ceiling{}, b_ceiling{};  // of a.dem and b.dem, for the rays cast onto them
};

// Step 3 for one target image of `site`: the candidate predicted into it through the gates (counted by the
// first that refuses it), matched on the DEM-warped grid and matched back. The observation goes into `tie`
// when it holds; true then.
bool matchIntoImage(const Pass& pass, const SiteImage& source, const SiteProducts& site, bool in_a,
                    const SiteImage& target, const Candidate& c, CrossTie& tie, Tally& tally) {
  const CrossTieParams& params = pass.params;
  const Eigen::Vector3d p = in_a ? c.pa : c.pb;
  auto bump = [&](int CrossTieCounts::*field) {
    ++(tally.all.*field);
    if (in_a) ++(tally.in_a.*field);
  };
  Vec2 pj;
  if (!ok(project(target.model, p, pj)) || !inside(target, pj, 2.0)) {
    bump(&CrossTieCounts::outside_image);
    return false;
  }
  const Eigen::Vector3d ray = p - target.model.c;
  const double range = ray.norm();
  if (range > params.max_range_m) {
    bump(&CrossTieCounts::beyond_range);
    return false;
  }
  if (std::fabs(c.normal.dot(ray / range)) < pass.sin_incidence) {
    bump(&CrossTieCounts::grazing);
    return false;
  }
  double hit = 0.0;
  const DemCeiling& ceiling = in_a ? pass.a_ceiling : pass.b_ceiling;
  if (castRayOnDem(site.dem, ceiling, target.model.c, ray / range, range + 1.0, hit) &&
      hit < range * (1.0 - params.occlusion_tolerance) - 0.05) {
    bump(&CrossTieCounts::occluded);
    return false;
  }
  Vec2 px, py;
  const Eigen::Vector3d gxs = in_a ? pass.pose.toA(c.gx) : c.gx, gys = in_a ? pass.pose.toA(c.gy) : c.gy;
  if (!ok(project(target.model, gxs, px)) || !ok(project(target.model, gys, py))) return false;
  Eigen::Matrix2d map;
  map.col(0) = (px - pj) / kFootprintStepPx;
  map.col(1) = (py - pj) / kFootprintStepPx;
  const double scale = std::sqrt(std::fabs(map.determinant()));
  if (!(scale <= pass.max_scale && scale >= 1.0 / pass.max_scale)) {
    bump(&CrossTieCounts::scale_gate);
    return false;
  }
  // The observation is the target's image of the ground that the source point's pixel sees; where the map
  // stretches that pixel over several target pixels, where in its span the ground lies is not known to the
  // match. The source point is known to within its pixel (uniform, sigma 1/sqrt(12) of a pixel): the map's
  // largest stretch carries that into the target, and its 3 sigma must stay within the geometric check's
  // residual floor, or a gross observation there could not be told from a good one.
  if (3.0 * largestStretch(map) / std::sqrt(12.0) > params.residual_floor_px) {
    bump(&CrossTieCounts::coarse_source);
    return false;
  }
  bump(&CrossTieCounts::predicted);
  const DemSurface forward(source.model, false, target.model, in_a, *c.surface_dem, c.surface_in_a, pass.pose,
                           c.surface_point);
  const DemSurface backward(target.model, in_a, source.model, false, *c.surface_dem, c.surface_in_a,
                            pass.pose, c.surface_point);
  const bool use_surface = params.surface_warp;
  PatchParams patch = params.patch;
  if (params.derived_radius) {
    if (!derivedRadius(target, p, in_a, pass.pose, pass.pose_cov, c, params, patch.radius_px)) return false;
    if (!(patch.radius_px <= kMaxSearchRadiusPx)) {
      bump(&CrossTieCounts::too_uncertain);
      return false;
    }
  }
  const PatchMatch m =
      matchWarpedPatch(source.pyramid, c.q, target.pyramid, pj, map, patch, use_surface ? &forward : nullptr);
  if (m.result != PatchResult::kOk) {
    countRefusal(m.result, tally.all);
    if (in_a) countRefusal(m.result, tally.in_a);
    return false;
  }
  // A match whose own precision puts its 3 sigma beyond the geometric check's residual floor could not be
  // told from a blunder by that check: refused (counted with the diverged ones).
  if (3.0 * std::sqrt(m.cov_px.trace()) > params.residual_floor_px) {
    countRefusal(PatchResult::kLsmDiverged, tally.all);
    if (in_a) countRefusal(PatchResult::kLsmDiverged, tally.in_a);
    return false;
  }
  bump(&CrossTieCounts::matched);
  // The back-match starts from the source point itself: the matcher's own pull-in is enough.
  PatchParams back_patch = params.patch;
  if (params.derived_radius) back_patch.radius_px = params.min_radius_px;
  const PatchMatch back = matchWarpedPatch(target.pyramid, m.j_px, source.pyramid, c.q, map.inverse(),
                                           back_patch, use_surface ? &backward : nullptr);
  const double tolerance = params.lr_tolerance_px * std::max(1.0, 1.0 / scale);
  // The round trip's miss counts in the target's pixels too (the local map carries it there): where one
  // source pixel spans several target pixels, a miss within the source's tolerance is still a disagreement
  // of the two matches that the geometric check, whose residual floor is in the observations' pixels, could
  // not tell from a blunder.
  if (back.result != PatchResult::kOk || (back.j_px - c.q).norm() > tolerance ||
      (map * (back.j_px - c.q)).norm() > params.residual_floor_px) {
    bump(&CrossTieCounts::back_failed);
    return false;
  }
  bump(&CrossTieCounts::back_matched);
  tie.observations.push_back({0, site.id, target.stem, m.j_px, false, m.ncc_final});
  return true;
}

}  // namespace

std::vector<std::vector<Eigen::Vector2d>> sourcePoints(const SiteProducts& b, const CrossTieParams& params) {
  std::vector<std::vector<Eigen::Vector2d>> points(b.images.size());
  const int border = params.patch.half + 2;
  cli::parallelFor(b.images.size(), 0, [&](std::size_t k) {
    auto workspace = std::make_unique<ForstnerWorkspace>();
    points[k] = interestPoints(b.images[k], params, border, *workspace);
  });
  return points;
}

void matchTies(const SiteProducts& a, const SiteProducts& b, const SourcePoints& points,
               const RelativePose& pose, const PoseMatrix& pose_cov, const CrossTieParams& params,
               int64_t first_point, int stride, CrossTieResult& out) {
  out.ties.clear();
  Pass pass{a, b, pose, pose_cov, params};
  pass.sin_incidence = std::sin(params.min_incidence_deg * kDegToRad);
  pass.max_scale = params.max_scale_ratio > 0.0
                       ? params.max_scale_ratio
                       : std::sqrt(2.0) * static_cast<double>(1 << (kPyramidLevels - 1));
  pass.a_ceiling = demCeiling(a.dem);
  pass.b_ceiling = demCeiling(b.dem);
  // Every stride-th interest point of every source image, in image order: each is matched on its own (in
  // parallel), and what they give is merged in this order, so that the ties and their point ids are the
  // same for any thread count.
  struct Item {
    int image = 0;
    std::size_t n = 0;
  };
  std::vector<Item> items;
  for (std::size_t k = 0; k < b.images.size(); ++k) {
    out.counts.interest_points += static_cast<int>(points[k].size());
    for (std::size_t n = 0; n < points[k].size(); n += static_cast<std::size_t>(stride))
      items.push_back({static_cast<int>(k), n});
  }
  struct Found {
    bool on_both_dems = false;
    bool any_a = false;
    CrossTie tie;
    Tally tally;
  };
  // Kept whole and merged after, not through cli::orderedFor: the items' costs differ widely, and a thread
  // done with an item would wait there for a slow earlier one.
  std::vector<Found> found(items.size());
  cli::parallelFor(items.size(), 0, [&](std::size_t i) {
    const SiteImage& source = b.images[items[i].image];
    Found& f = found[i];
    Candidate c;
    const bool cast = castCandidate(a, b, pass.b_ceiling, pose, params, source,
                                    points[items[i].image][items[i].n], pass.sin_incidence, c);
    f.on_both_dems = c.on_both_dems;
    if (!cast) return;
    f.tie.b_m = c.pb;
    f.tie.observations.push_back({0, b.id, source.stem, c.q, true, 1.0});
    for (int side = 0; side < 2; ++side) {
      const bool in_a = side == 0;
      const SiteProducts& site = in_a ? a : b;
      for (const SiteImage& target : site.images) {
        if (&target == &source) continue;
        if (matchIntoImage(pass, source, site, in_a, target, c, f.tie, f.tally)) f.any_a = f.any_a || in_a;
      }
    }
  });
  int64_t next_point = first_point;
  for (Found& f : found) {
    if (f.on_both_dems) ++out.counts.on_both_dems;
    out.counts += f.tally.all;
    out.counts_in_a += f.tally.in_a;
    if (!f.any_a) continue;
    f.tie.point = next_point;
    for (CrossTieObservation& o : f.tie.observations) o.point = next_point;
    out.ties.push_back(std::move(f.tie));
    ++next_point;
  }
}

}  // namespace areomap::traverse
