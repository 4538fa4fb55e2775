// Step 4 of the cross-site ties (CrossTieSteps.hpp): the geometric check, a bundle of the site pose
// (x, y, z, heading and, where the registration solves it, the tilt of B in A) and every tie's point from
// all observations under a weak prior, trimmed round by round, then the ties whose point leaves either
// site's DEM dropped.
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "firmware_core/base/Angles.hpp"
#include "ground/traverse/CrossTieSteps.hpp"

namespace areomap::traverse {

namespace {

constexpr int kGaussNewtonSteps = 6;  // per round of the geometric check

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

// The geometric check's state: every observation of every tie, the ties' points (B's frame) and the pose.
struct CheckState {
  std::vector<GeoObservation> geo;
  std::vector<std::vector<int>> of_tie;  // per tie, its observations' indices in geo
  std::vector<bool> tie_alive;
  std::vector<Eigen::Vector3d> x;
  RelativePose current;
  PoseMatrix reduced = PoseMatrix::Identity();  // the pose's normal matrix, points eliminated
  double rms = 0.0;
};

void gatherObservations(const SiteProducts& a, const SiteProducts& b, const CrossTieResult& out,
                        CheckState& s) {
  s.of_tie.resize(out.ties.size());
  for (std::size_t i = 0; i < out.ties.size(); ++i) {
    for (std::size_t k = 0; k < out.ties[i].observations.size(); ++k) {
      const CrossTieObservation& ob = out.ties[i].observations[k];
      const bool in_a = ob.site == a.id;
      const SiteProducts& site = in_a ? a : b;
      s.of_tie[i].push_back(static_cast<int>(s.geo.size()));
      s.geo.push_back({static_cast<int>(i), static_cast<int>(k), &site.images[site.indexOf(ob.image)].model,
                       in_a, ob.pixel_px, true});
    }
  }
  s.tie_alive.assign(out.ties.size(), true);
  s.x.resize(out.ties.size());
}

// Gauss-Newton steps of the pose (x, y, z, heading of B in A, and its tilt when prior_sigma gives the tilt a
// sigma; else the tilt is held) and the live ties' points, the points eliminated by their 3x3 blocks, with
// the weak prior on `prior`.
void gaussNewtonSteps(const RelativePose& prior, const PoseVector& prior_sigma, std::size_t ties,
                      CheckState& s) {
  const bool tilt = prior_sigma[4] > 0.0 && prior_sigma[5] > 0.0;
  const int unknowns = tilt ? 6 : 4;
  for (int it = 0; it < kGaussNewtonSteps; ++it) {
    s.reduced.setZero();
    PoseVector g = PoseVector::Zero();
    PoseVector offset;
    offset << s.current.translation_m - prior.translation_m, s.current.heading_rad - prior.heading_rad,
        s.current.tilt_rad - prior.tilt_rad;
    for (int c = 0; c < unknowns; ++c) {
      s.reduced(c, c) += 1.0 / (prior_sigma[c] * prior_sigma[c]);
      g[c] += offset[c] / (prior_sigma[c] * prior_sigma[c]);
    }
    std::vector<Eigen::Matrix3d> hxx(ties);
    std::vector<Eigen::Matrix<double, 3, 6>> hxc(ties);
    std::vector<Eigen::Vector3d> gx(ties);
    const Eigen::Matrix3d r = s.current.rotation();
    for (std::size_t i = 0; i < ties; ++i) {
      if (!s.tie_alive[i]) continue;
      hxx[i].setZero();
      hxc[i].setZero();
      gx[i].setZero();
      PoseMatrix hcc = PoseMatrix::Zero();
      PoseVector gc = PoseVector::Zero();
      for (int k : s.of_tie[i]) {
        const GeoObservation& ob = s.geo[k];
        if (!ob.active) continue;
        Vec2 pixel;
        Mat2x3 dp;
        const Eigen::Vector3d rx = r * s.x[i];
        const Eigen::Vector3d p = ob.in_a ? Eigen::Vector3d(rx + s.current.translation_m) : s.x[i];
        if (!ok(project(*ob.model, p, pixel, &dp))) continue;
        const Eigen::Vector2d res = pixel - ob.pixel;
        Eigen::Matrix<double, 2, 3> jx = dp;
        Eigen::Matrix<double, 2, 6> jc = Eigen::Matrix<double, 2, 6>::Zero();
        if (ob.in_a) {
          jx = dp * r;
          jc.leftCols<3>() = dp;
          jc.col(3) = dp * Eigen::Vector3d(-rx.y(), rx.x(), 0.0);
          if (tilt) jc.rightCols<2>() = dp * turnJacobian(rx).leftCols<2>();
        }
        hxx[i].noalias() += jx.transpose() * jx;
        hxc[i].noalias() += jx.transpose() * jc;
        gx[i].noalias() += jx.transpose() * res;
        hcc.noalias() += jc.transpose() * jc;
        gc.noalias() += jc.transpose() * res;
      }
      hxx[i] += 1e-9 * Eigen::Matrix3d::Identity();
      const Eigen::Matrix3d inv = hxx[i].inverse();
      s.reduced += hcc - hxc[i].transpose() * inv * hxc[i];
      g += gc - hxc[i].transpose() * inv * gx[i];
    }
    PoseVector dc = PoseVector::Zero();
    if (tilt) {
      dc = -s.reduced.ldlt().solve(g);
    } else {
      dc.head<4>() = -s.reduced.topLeftCorner<4, 4>().ldlt().solve(g.head<4>());
    }
    if (!dc.allFinite()) break;
    s.current.translation_m += dc.head<3>();
    if (tilt) {
      s.current = turnedPose(s.current, Eigen::Vector3d(dc[4], dc[5], dc[3]));
    } else {
      s.current.heading_rad += dc[3];
    }
    for (std::size_t i = 0; i < ties; ++i) {
      if (s.tie_alive[i]) s.x[i] += -hxx[i].inverse() * (gx[i] + hxc[i] * dc);
    }
  }
}

// Residuals, their robust sigma and the rejection: per live tie its worst observation beyond
// max(floor, k sigmas) goes (and the tie with it when that was its source or its last of either site).
// Returns the observations dropped, -1 when no observation is left.
int rejectWorst(const CrossTieParams& params, CrossTieResult& out, CheckState& s) {
  std::vector<double> norms;
  std::vector<double> res_of(s.geo.size(), 0.0);
  const Eigen::Matrix3d r = s.current.rotation();
  for (std::size_t k = 0; k < s.geo.size(); ++k) {
    if (!s.geo[k].active || !s.tie_alive[s.geo[k].tie]) continue;
    const Eigen::Vector3d& xi = s.x[s.geo[k].tie];
    const Eigen::Vector3d p = s.geo[k].in_a ? Eigen::Vector3d(r * xi + s.current.translation_m) : xi;
    Vec2 pixel;
    res_of[k] = ok(project(*s.geo[k].model, p, pixel)) ? (pixel - s.geo[k].pixel).norm() : 1e9;
    norms.push_back(res_of[k]);
  }
  if (norms.empty()) return -1;
  double sq = 0.0;
  for (double v : norms) sq += v * v;
  s.rms = std::sqrt(sq / static_cast<double>(norms.size()));
  std::vector<double> sorted = norms;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  // The norm of a 2-D residual: its median is 1.1774 sigma for Gaussian components.
  const double sigma = sorted[sorted.size() / 2] / 1.1774;
  const double limit = std::max(params.residual_floor_px, params.residual_sigmas * sigma);
  int dropped = 0;
  for (std::size_t i = 0; i < out.ties.size(); ++i) {
    if (!s.tie_alive[i]) continue;
    // Per tie, drop its worst observation beyond the limit.
    int worst = -1;
    for (int k : s.of_tie[i]) {
      if (s.geo[k].active && res_of[k] > limit && (worst < 0 || res_of[k] > res_of[worst])) worst = k;
    }
    if (worst < 0) continue;
    s.geo[worst].active = false;
    ++dropped;
    ++out.counts.rejected_observations;
    bool has_a = false, has_b = false;
    for (int k : s.of_tie[i]) {
      if (!s.geo[k].active) continue;
      (s.geo[k].in_a ? has_a : has_b) = true;
    }
    const bool source_lost = out.ties[i].observations[s.geo[worst].obs].source;
    if (source_lost || !has_a || !has_b) {
      s.tie_alive[i] = false;
      ++out.counts.rejected_ties;
    }
  }
  return dropped;
}

// Parallax discipline against the DEMs: the point triangulated from all the views must lie on both sites'
// surfaces within their height sigmas (a match that slid along the other site's rays moves it off).
void dropOffDemTies(const SiteProducts& a, const SiteProducts& b, const CrossTieParams& params,
                    CrossTieResult& out, CheckState& s) {
  for (std::size_t i = 0; i < out.ties.size(); ++i) {
    if (!s.tie_alive[i]) continue;
    const Eigen::Vector3d xa = s.current.toA(s.x[i]);
    bool on_both = true;
    for (const auto& [site, p] : {std::pair<const SiteProducts*, Eigen::Vector3d>{&b, s.x[i]}, {&a, xa}}) {
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
      s.tie_alive[i] = false;
      ++out.counts.off_dem_ties;
    }
  }
}

}  // namespace

void checkTies(const SiteProducts& a, const SiteProducts& b, const RelativePose& pose,
               const CrossTieParams& params, CrossTieResult& out) {
  CheckState s;
  gatherObservations(a, b, out, s);
  s.current = pose;
  // The tilt's prior is the registration's (the two frames' levelling by their attitudes), about the pose's.
  PoseVector prior_sigma;
  prior_sigma << params.prior_sigma_m, params.prior_sigma_m, params.prior_sigma_m,
      params.prior_sigma_deg * kDegToRad, params.registration.tilt_sigma_rad,
      params.registration.tilt_sigma_rad;
  for (int round = 0; round < params.max_check_rounds; ++round) {
    for (std::size_t i = 0; i < out.ties.size(); ++i) {
      if (s.tie_alive[i] && !triangulate(s.geo, s.of_tie[i], s.current, s.x[i])) s.tie_alive[i] = false;
    }
    gaussNewtonSteps(pose, prior_sigma, out.ties.size(), s);
    if (rejectWorst(params, out, s) <= 0) break;
  }
  PoseMatrix cov = PoseMatrix::Zero();
  const double variance_px2 = std::max(s.rms * s.rms / 2.0, 1e-6);
  if (prior_sigma[4] > 0.0) {
    cov = s.reduced.inverse() * variance_px2;
  } else {
    cov.topLeftCorner<4, 4>() = s.reduced.topLeftCorner<4, 4>().inverse() * variance_px2;
  }
  out.a_from_b_covariance = cov;
  for (int c = 0; c < 6; ++c) out.a_from_b_sigma[c] = std::sqrt(std::max(0.0, cov(c, c)));
  out.a_from_b = s.current;
  out.rms_px = s.rms;
  dropOffDemTies(a, b, params, out, s);

  // Kept ties with their kept observations.
  std::vector<CrossTie> kept;
  for (std::size_t i = 0; i < out.ties.size(); ++i) {
    if (!s.tie_alive[i]) continue;
    CrossTie t = out.ties[i];
    t.b_m = s.x[i];
    t.observations.clear();
    for (int k : s.of_tie[i]) {
      if (s.geo[k].active) t.observations.push_back(out.ties[i].observations[s.geo[k].obs]);
    }
    kept.push_back(std::move(t));
  }
  out.ties = std::move(kept);
}

}  // namespace areomap::traverse
