#include "ground/traverse/DemRegistration.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "firmware_core/base/Angles.hpp"
#include "ground/cli/Parallel.hpp"
#include "ground/traverse/CrossSiteAdjustment.hpp"
#include "ground/traverse/DemCost.hpp"
#include "ground/traverse/OrthoRegistration.hpp"

namespace areomap::traverse {

namespace {

using demcost::designEffect;
using demcost::kFloorSigmaM;
using demcost::Moments;
using demcost::moments;
using demcost::Sample;
using demcost::samplesOf;
using demcost::sigmaAt;

constexpr int kMaxGaussNewtonIterations = 40;

struct Candidate {
  double dx = 0.0, dy = 0.0, dh = 0.0, cost = std::numeric_limits<double>::infinity();
};

std::string format(const char* fmt, double a, double b = 0.0, double c = 0.0) {
  char buffer[160];
  std::snprintf(buffer, sizeof buffer, fmt, a, b, c);
  return buffer;
}

// Why a registration was refused, in the data's own figures: how far apart the DEMs are at the solution
// against their dem_sigma layers; how much the relief they share changes their differences between the
// coarse search's best pose and its second minimum against the differences at the best (below the signal
// to noise that max_cost_ratio stands for, sqrt(1 / max_cost_ratio - 1), the DEMs' errors, not their relief,
// decide where the fit goes); and, when the fit did not converge, how far it drifted from the search's best.
std::string noiseAgainstRelief(const DemRegistration& r, const RegistrationParams& params) {
  std::string s;
  if (r.difference_rms_m > 0.0) {
    s = format("the DEMs differ by %.1f cm RMS (their dem_sigma layers give %.1f cm); ",
               100.0 * r.difference_rms_m, 100.0 * r.dem_sigma_rms_m);
  }
  if (r.relief_signal_m > 0.0) {
    s += format("the relief they share changes their differences by %.1f cm RMS", 100.0 * r.relief_signal_m) +
         format(" between the best pose and a second minimum %.2f m, %.1f deg away", r.second_offset_m,
                r.second_offset_deg) +
         format(" against %.1f cm at the best", 100.0 * r.coarse_rms_m);
    const double snr = r.relief_signal_m / std::max(r.coarse_rms_m, 1e-9);
    if (snr < std::sqrt(1.0 / params.max_cost_ratio - 1.0))
      s += format(": the DEMs are too noisy for the relief they share (signal to noise %.2f)", snr);
  }
  if (r.status == RegistrationStatus::kNotConverged && r.drift_m + r.drift_deg > 0.0) {
    if (s.size() >= 2 && s.compare(s.size() - 2, 2, "; ") == 0) s.resize(s.size() - 2);
    s += format("; the fit drifted %.2f m and %.1f deg from the search's best", r.drift_m, r.drift_deg);
  }
  return s;
}

// The coarse search's grid of poses about the a-priori one: nxy steps of step_m each side in x and y, nh of
// step_rad in heading, and the variance of the elevation differences at each (infinite where too few
// samples are common), about their levelling plane where the tilt is solved.
struct CoarseGrid {
  double step_m = 0.0, step_rad = 0.0;
  int nxy = 0, nh = 0, sx = 0, sh = 0;
  std::vector<double> cost;
  std::size_t index(int i, int j, int k) const { return (static_cast<std::size_t>(k) * sx + j) * sx + i; }
  Candidate at(int i, int j, int k) const {
    return {(i - nxy) * step_m, (j - nxy) * step_m, (k - nh) * step_rad, cost[index(i, j, k)]};
  }
};

void coarseCosts(const SiteProducts& a, const DemGrid& coarse_a, const std::vector<Sample>& coarse_samples,
                 const RelativePose& apriori, const RegistrationParams& params, int min_coarse,
                 CoarseGrid& g) {
  g.nxy = static_cast<int>(std::lround(params.search_m / g.step_m));
  g.nh = static_cast<int>(std::lround(params.search_deg * kDegToRad / g.step_rad));
  g.sx = 2 * g.nxy + 1;
  g.sh = 2 * g.nh + 1;
  g.cost.assign(static_cast<std::size_t>(g.sx) * g.sx * g.sh, std::numeric_limits<double>::infinity());
  // Each candidate's cost into its own slot, in parallel.
  const std::size_t per_heading = static_cast<std::size_t>(g.sx) * g.sx;
  cli::parallelFor(g.cost.size(), 0, [&](std::size_t n) {
    const int k = static_cast<int>(n / per_heading);
    const int j = static_cast<int>(n % per_heading) / g.sx, i = static_cast<int>(n % per_heading) % g.sx;
    const Moments m =
        moments(a, coarse_a, coarse_samples,
                shiftedPose(apriori, (i - g.nxy) * g.step_m, (j - g.nxy) * g.step_m, (k - g.nh) * g.step_rad),
                params);
    if (m.n >= min_coarse) g.cost[g.index(i, j, k)] = m.levelledVariance(params.tilt_sigma_rad);
  });
}

Candidate bestOf(const CoarseGrid& g) {
  Candidate best;
  for (int k = 0; k < g.sh; ++k) {
    for (int j = 0; j < g.sx; ++j) {
      for (int i = 0; i < g.sx; ++i) {
        if (g.cost[g.index(i, j, k)] < best.cost) best = g.at(i, j, k);
      }
    }
  }
  return best;
}

bool localMinimum(const CoarseGrid& g, int i, int j, int k) {
  const double c = g.cost[g.index(i, j, k)];
  for (int dk = -1; dk <= 1; ++dk) {
    for (int dj = -1; dj <= 1; ++dj) {
      for (int di = -1; di <= 1; ++di) {
        const int ii = i + di, jj = j + dj, kk = k + dk;
        if ((di == 0 && dj == 0 && dk == 0) || ii < 0 || jj < 0 || kk < 0 || ii >= g.sx || jj >= g.sx ||
            kk >= g.sh) {
          continue;
        }
        if (g.cost[g.index(ii, jj, kk)] < c) return false;
      }
    }
  }
  return true;
}

// The second minimum: the lowest local minimum of the coarse cost away from the best (cost infinite when
// there is none).
Candidate secondMinimum(const CoarseGrid& g, const Candidate& best, const RegistrationParams& params) {
  Candidate second;
  for (int k = 0; k < g.sh; ++k) {
    for (int j = 0; j < g.sx; ++j) {
      for (int i = 0; i < g.sx; ++i) {
        const double c = g.cost[g.index(i, j, k)];
        if (!std::isfinite(c) || c >= second.cost) continue;
        const double dx = (i - g.nxy) * g.step_m - best.dx, dy = (j - g.nxy) * g.step_m - best.dy;
        const double dh = (k - g.nh) * g.step_rad - best.dh;
        if (std::hypot(dx, dy) < params.second_min_distance_m &&
            std::fabs(dh) < params.second_min_deg * kDegToRad) {
          continue;
        }
        if (localMinimum(g, i, j, k)) second = g.at(i, j, k);
      }
    }
  }
  return second;
}

// Fine: +-1.5 coarse steps in quarter steps, +-1.2 coarse heading steps in fifths, on the full DEMs.
Candidate fineSearch(const SiteProducts& a, const SiteProducts& b, const RelativePose& apriori,
                     const RegistrationParams& params, const CoarseGrid& g, const Candidate& best,
                     int min_samples) {
  Candidate fine = best;
  fine.cost = std::numeric_limits<double>::infinity();
  const std::vector<Sample> fine_samples =
      samplesOf(b, b.dem, std::max(params.sample_spacing_m, 0.1), params);
  // Every candidate's cost in parallel, then the best of them in the order of the grid (the first of equals).
  constexpr int kSide = 13;
  std::vector<Candidate> grid(static_cast<std::size_t>(kSide) * kSide * kSide);
  cli::parallelFor(grid.size(), 0, [&](std::size_t n) {
    const int k = static_cast<int>(n) / (kSide * kSide) - 6;
    const int j = static_cast<int>(n) / kSide % kSide - 6, i = static_cast<int>(n) % kSide - 6;
    const double dx = best.dx + g.step_m / 4.0 * i, dy = best.dy + g.step_m / 4.0 * j;
    const double dh = best.dh + g.step_rad / 5.0 * k;
    const Moments m = moments(a, a.dem, fine_samples, shiftedPose(apriori, dx, dy, dh), params);
    grid[n] = {dx, dy, dh,
               m.n >= min_samples / 2 ? m.levelledVariance(params.tilt_sigma_rad)
                                      : std::numeric_limits<double>::infinity()};
  });
  for (const Candidate& c : grid) {
    if (c.cost < fine.cost) fine = c;
  }
  return fine;
}

// The Gauss-Newton fit's state: the pose, the data's normal matrix (weights 1 / sigma^2 of the cells), the
// weighted residual's sigma, and the tilt prior's information (zero: the tilt held).
struct Fit {
  RelativePose pose;
  PoseMatrix normal = PoseMatrix::Identity();
  double s0 = 0.0;
  double tilt_information = 0.0;  // 1 / tilt_sigma_rad^2 per axis
  Eigen::Vector2d tilt_prior = Eigen::Vector2d::Zero();
  bool solvesTilt() const { return tilt_information > 0.0; }
  // The covariance of the solution: the data's normal matrix scaled to information by s0^2 and the design
  // effect `factor` of their spatial correlation, plus the tilt's prior row.
  PoseMatrix information(double factor) const {
    PoseMatrix info = normal / std::max(s0 * s0 * factor, 1e-12);
    info(4, 4) += tilt_information;
    info(5, 5) += tilt_information;
    return info;
  }
};

// The step of one Gauss-Newton iteration: x, y, z, heading alone when the tilt is held (as a levelled
// registration), else all six with the tilt's prior row weighed against the data's information (s0^2 and
// the design effect `factor`).
PoseVector gaussNewtonStep(const Fit& fit, const PoseVector& rhs, double factor) {
  PoseVector delta = PoseVector::Zero();
  if (!fit.solvesTilt()) {
    delta.head<4>() = -fit.normal.topLeftCorner<4, 4>().ldlt().solve(rhs.head<4>());
    return delta;
  }
  PoseVector g = rhs / std::max(fit.s0 * fit.s0 * factor, 1e-12);
  g.tail<2>() += fit.tilt_information * (fit.pose.tilt_rad - fit.tilt_prior);
  return -fit.information(factor).ldlt().solve(g);
}

// Gauss-Newton on the elevation differences against `dem_a` (gradients over +-h), reweighted and trimmed at
// 3 robust sigmas; the tilt solved when fit.solvesTilt(), its prior weighed with the design effect
// `factor`. False when fewer than min_used samples count or a step is not finite; `converged` when the step
// settled within the iterations.
bool gaussNewton(const SiteProducts& a, const DemGrid& dem_a, const std::vector<Sample>& used, double h,
                 int min_used, double factor, const RegistrationParams& params, Fit& fit,
                 DemRegistration& out, bool& converged) {
  double trim = std::numeric_limits<double>::infinity();
  converged = false;
  const int unknowns = fit.solvesTilt() ? 6 : 4;
  for (int it = 0; it < kMaxGaussNewtonIterations; ++it) {
    fit.normal.setZero();
    PoseVector rhs = PoseVector::Zero();
    std::vector<double> abs_d;
    double wrr = 0.0;
    int n = 0, total = 0;
    const Eigen::Matrix3d r = fit.pose.rotation();
    for (const Sample& s : used) {
      const Eigen::Vector3d rb = r * s.b_m;
      const Eigen::Vector3d p = rb + fit.pose.translation_m;
      if (p.head<2>().squaredNorm() > params.max_range_m * params.max_range_m) continue;
      const double e = demElevation(dem_a, p.x(), p.y());
      const double ex =
          (demElevation(dem_a, p.x() + h, p.y()) - demElevation(dem_a, p.x() - h, p.y())) / (2 * h);
      const double ey =
          (demElevation(dem_a, p.x(), p.y() + h) - demElevation(dem_a, p.x(), p.y() - h)) / (2 * h);
      if (!std::isfinite(e) || !std::isfinite(ex) || !std::isfinite(ey)) continue;
      const double sa = sigmaAt(a.dem_sigma, p.x(), p.y());
      if (sa > params.max_sigma_m) continue;
      const double d = e + p.z();
      ++total;
      abs_d.push_back(std::fabs(d));
      if (std::fabs(d) > trim) continue;
      const double w = 1.0 / (kFloorSigmaM * kFloorSigmaM + sa * sa + s.sigma2);
      // d = e_a(p) + p_z: its derivatives by p are (ex, ey, 1); a turn about A's axes moves p by
      // turnJacobian(rb) omega.
      const Eigen::Vector3d dd_dp(ex, ey, 1.0);
      const Eigen::RowVector3d dd_domega = dd_dp.transpose() * turnJacobian(rb);
      PoseVector j;
      j << ex, ey, 1.0, ex * -rb.y() + ey * rb.x(), dd_domega.x(), dd_domega.y();
      fit.normal.noalias() += w * j * j.transpose();
      rhs += w * j * d;
      wrr += w * d * d;
      ++n;
    }
    if (n < min_used) return false;
    out.overlap_cells = total;
    out.used_cells = n;
    fit.s0 = std::sqrt(wrr / std::max(1, n - unknowns));
    const PoseVector delta = gaussNewtonStep(fit, rhs, factor);
    if (!delta.allFinite()) return false;
    fit.pose.translation_m += delta.head<3>();
    if (fit.solvesTilt()) {
      fit.pose = turnedPose(fit.pose, Eigen::Vector3d(delta[4], delta[5], delta[3]));
    } else {
      fit.pose.heading_rad += delta[3];
    }
    // The trimming threshold settles after a few steps (so that the set of samples stops changing).
    if (it < 4) {
      std::nth_element(abs_d.begin(), abs_d.begin() + abs_d.size() / 2, abs_d.end());
      trim = std::max(3.0 * 1.4826 * abs_d[abs_d.size() / 2], 0.01);
    }
    if (it >= 4 && delta.head<3>().norm() < 5e-4 && delta.tail<3>().cwiseAbs().maxCoeff() < 1e-5) {
      converged = true;
      return true;
    }
  }
  return true;
}

// The result's figures at the solution and its status (the a-priori pose kept when it is not kOk).
void judgeSolution(const SiteProducts& a, const std::vector<Sample>& samples, const RelativePose& apriori,
                   const RegistrationParams& params, const Fit& fit, bool converged, const std::string& pair,
                   DemRegistration& out) {
  // Weighted RMS elevation difference at the solution (every common sample, untrimmed).
  const Moments at_solution = moments(a, a.dem, samples, fit.pose, params);
  out.rms_m = std::sqrt(at_solution.wdd / at_solution.w);
  out.difference_rms_m = std::sqrt(at_solution.dd / at_solution.n);
  out.dem_sigma_rms_m = std::sqrt(at_solution.ss / at_solution.n);
  out.correlation_factor = designEffect(a, samples, fit.pose, params, out.rms_m);
  PoseMatrix cov = PoseMatrix::Zero();
  if (fit.solvesTilt()) {
    cov = fit.information(out.correlation_factor).inverse();
  } else {
    cov.topLeftCorner<4, 4>() =
        fit.normal.topLeftCorner<4, 4>().inverse() * fit.s0 * fit.s0 * out.correlation_factor;
  }
  out.covariance = cov;
  for (int i = 0; i < 6; ++i) out.sigma[i] = std::sqrt(std::max(0.0, cov(i, i)));
  out.a_from_b = fit.pose;
  const double moved = (fit.pose.translation_m - apriori.translation_m).head<2>().norm();
  if (!converged) {
    out.status = RegistrationStatus::kNotConverged;
    out.message = pair + ": the DEM registration did not converge";
  } else if (out.cost_ratio > params.max_cost_ratio) {
    out.status = RegistrationStatus::kAmbiguous;
    out.message =
        pair + ": the DEM match is ambiguous (best/second minimum " + std::to_string(out.cost_ratio) + ")";
  } else if (moved > params.search_m * 1.5) {
    out.status = RegistrationStatus::kNotConverged;
    out.message = pair + ": the DEM registration left the search window";
  } else {
    out.status = RegistrationStatus::kOk;
  }
  if (out.status != RegistrationStatus::kOk) {
    out.message += ": " + noiseAgainstRelief(out, params);
    out.a_from_b = apriori;
  }
}

// A refused DEM registration is tried again on the orthoimages (OrthoRegistration.hpp): where they
// register, theirs is the pose (its height the DEMs' weighted mean difference there) and `message` keeps
// why the DEMs did not.
void tryOrthos(const SiteProducts& a, const std::vector<Sample>& samples, const SiteProducts& b,
               const RegistrationParams& params, DemRegistration& out) {
  const OrthoRegistration o = registerOrthos(a, b, out.apriori, params);
  out.ortho_ncc = o.ncc;
  if (!o.ok) {
    if (a.ortho && b.ortho) out.message += "; " + o.message;
    return;
  }
  RelativePose pose = o.a_from_b;
  const Moments m = moments(a, a.dem, samples, pose, params);
  if (m.n < 20) return;
  pose.translation_m.z() -= m.mean();
  out.a_from_b = pose;
  // The orthos' pose is levelled: its tilt the a-priori one, known to the tilt's prior.
  out.covariance.setZero();
  out.covariance.topLeftCorner<4, 4>() = o.covariance;
  out.covariance(4, 4) = out.covariance(5, 5) = params.tilt_sigma_rad * params.tilt_sigma_rad;
  out.covariance(2, 2) = m.variance();  // the height from the mean difference: the differences' spread
  for (int i = 0; i < 6; ++i) out.sigma[i] = std::sqrt(std::max(0.0, out.covariance(i, i)));
  out.status = RegistrationStatus::kOk;
  out.method = "ortho";
  out.message += format("; the orthoimages registered instead (NCC %.2f, second peak %.2f, median %.2f)",
                        o.ncc, o.second_ncc, o.median_ncc);
}

}  // namespace

namespace {

Eigen::Matrix3d headingRotation(double heading_rad) {
  const double c = std::cos(heading_rad), s = std::sin(heading_rad);
  Eigen::Matrix3d r;
  r << c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0;
  return r;
}

Eigen::Matrix3d rotationOf(const Eigen::Vector3d& omega_rad) {
  const double angle = omega_rad.norm();
  if (angle == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, omega_rad / angle).toRotationMatrix();
}

}  // namespace

RelativePose relativePoseOf(const Eigen::Matrix3d& r, const Eigen::Vector3d& translation_m) {
  RelativePose p;
  p.translation_m = translation_m;
  const Eigen::Vector3d up = r.col(2);
  const Eigen::Vector3d axis = Eigen::Vector3d::UnitZ().cross(up);
  const double angle = std::atan2(axis.norm(), up.z());
  if (axis.norm() > 0.0) p.tilt_rad = (axis / axis.norm() * angle).head<2>();
  const Eigen::Matrix3d heading =
      rotationOf(Eigen::Vector3d(p.tilt_rad.x(), p.tilt_rad.y(), 0.0)).transpose() * r;
  p.heading_rad = std::atan2(heading(1, 0), heading(0, 0));
  return p;
}

Eigen::Matrix3d RelativePose::rotation() const {
  // A levelled pose is Rz alone, not multiplied by an identity tilt (the same bits as before tilts).
  if (tilt_rad.isZero(0.0)) return headingRotation(heading_rad);
  return rotationOf(Eigen::Vector3d(tilt_rad.x(), tilt_rad.y(), 0.0)) * headingRotation(heading_rad);
}

RelativePose RelativePose::inverse() const {
  RelativePose inv;
  inv.heading_rad = -heading_rad;
  inv.translation_m = -(rotation().transpose() * translation_m);
  if (!tilt_rad.isZero(0.0)) {
    // R^T = Rz(-h) exp(-[t]x) = exp(-[Rz(-h) t]x) Rz(-h), and Rz(-h) t stays horizontal.
    inv.tilt_rad =
        -(headingRotation(-heading_rad) * Eigen::Vector3d(tilt_rad.x(), tilt_rad.y(), 0.0)).head<2>();
  }
  return inv;
}

RelativePose turnedPose(const RelativePose& base, const Eigen::Vector3d& omega_rad) {
  return relativePoseOf(rotationOf(omega_rad) * base.rotation(), base.translation_m);
}

Eigen::Matrix3d turnJacobian(const Eigen::Vector3d& rotated_b) {
  Eigen::Matrix3d j;  // omega x v = -[v]x omega
  j << 0.0, rotated_b.z(), -rotated_b.y(), -rotated_b.z(), 0.0, rotated_b.x(), rotated_b.y(), -rotated_b.x(),
      0.0;
  return j;
}

RelativePose shiftedPose(const RelativePose& base, double dx, double dy, double dh) {
  RelativePose p = base;
  p.translation_m.x() += dx;
  p.translation_m.y() += dy;
  p.heading_rad += dh;
  return p;
}

RelativePose relativePose(const SitePose& a, const SitePose& b) {
  RelativePose p;
  p.heading_rad = b.heading_rad - a.heading_rad;
  p.translation_m = a.rotation().transpose() * (b.position_m - a.position_m);
  return p;
}

RegistrationParams searchWindowOf(const Traverse& traverse, int i, int j, const RegistrationParams& base) {
  // Site k's pose in site i's frame, x_k = x_{k-1} + Rz(h_{k-1}) delta_k, h_k = h_{k-1} + dh_k, its
  // covariance propagated leg by leg (as odometryPoses does from the first site).
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();  // x, y, heading
  double h = 0.0;
  for (int k = i + 1; k <= j; ++k) {
    const OdometryLeg& leg = *traverse.sites[k].odometry;
    const double c = std::cos(h), s = std::sin(h);
    Eigen::Matrix3d f = Eigen::Matrix3d::Identity();
    f(0, 2) = -s * leg.delta_m.x() - c * leg.delta_m.y();
    f(1, 2) = c * leg.delta_m.x() - s * leg.delta_m.y();
    Eigen::Matrix3d g = Eigen::Matrix3d::Zero();
    g << c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0;
    const Eigen::Vector3d q(leg.sigma_m.x() * leg.sigma_m.x(), leg.sigma_m.y() * leg.sigma_m.y(),
                            leg.sigma_heading_rad * leg.sigma_heading_rad);
    cov = f * cov * f.transpose() + g * q.asDiagonal() * g.transpose();
    h += leg.delta_heading_rad;
  }
  RegistrationParams p = base;
  // The window is square in x and y: 3 sigmas along the covariance's major axis.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> xy(cov.topLeftCorner<2, 2>());
  p.three_sigma_m = 3.0 * std::sqrt(std::max(0.0, xy.eigenvalues().maxCoeff()));
  p.three_sigma_deg = 3.0 * std::sqrt(std::max(0.0, cov(2, 2))) / kDegToRad;
  p.search_m = std::min(std::max(p.three_sigma_m, base.search_m), kMaxSearchM);
  p.search_deg = std::min(std::max(p.three_sigma_deg, base.search_deg), kMaxSearchDeg);
  const double attitude2 = traverse.sites[i].attitude_sigma_rad * traverse.sites[i].attitude_sigma_rad +
                           traverse.sites[j].attitude_sigma_rad * traverse.sites[j].attitude_sigma_rad;
  p.tilt_sigma_rad = std::sqrt(std::max(kLevelSigmaRad * kLevelSigmaRad, attitude2));
  return p;
}

double coarseStepM(const RegistrationParams& params) {
  return std::max(0.2, params.search_m / 10.0);
}

double coarseStepRad(const RegistrationParams& params) {
  return std::max(1.0, params.search_deg / 5.0) * kDegToRad;
}

std::string windowCut(const RegistrationParams& p) {
  std::string s;
  if (p.three_sigma_m > p.search_m * (1.0 + 1e-9))
    s = format("+-%.1f m of the odometry's 3-sigma +-%.1f m", p.search_m, p.three_sigma_m);
  if (p.three_sigma_deg > p.search_deg * (1.0 + 1e-9))
    s += (s.empty() ? "" : " and ") +
         format("+-%.1f deg of its 3-sigma +-%.1f deg", p.search_deg, p.three_sigma_deg);
  return s.empty() ? s : "the DEM registration's search window covers only " + s;
}

DemRegistration registerOrthosInstead(const SiteProducts& a, const SiteProducts& b, DemRegistration refused,
                                      const std::string& why, const RegistrationParams& params) {
  refused.status = RegistrationStatus::kNotConverged;
  refused.a_from_b = refused.apriori;
  refused.message = why;
  tryOrthos(a, samplesOf(b, b.dem, params.sample_spacing_m, params), b, params, refused);
  return refused;
}

const char* registrationStatusName(RegistrationStatus status) {
  switch (status) {
    case RegistrationStatus::kOk:
      return "ok";
    case RegistrationStatus::kNoOverlap:
      return "no_overlap";
    case RegistrationStatus::kAmbiguous:
      return "ambiguous";
    case RegistrationStatus::kNotConverged:
      return "not_converged";
  }
  return "unknown";
}

DemRegistration registerDems(const SiteProducts& a, const SiteProducts& b, const RelativePose& apriori,
                             const RegistrationParams& params) {
  DemRegistration out;
  out.apriori = apriori;
  out.a_from_b = apriori;
  const std::string pair = "sites " + a.id + " and " + b.id;

  // Coarse: both DEMs averaged to ~0.2 m, steps of 0.2 m and 1 degree.
  // The coarse steps grow with the search window (about 10 steps each side, at least 0.2 m and 1 degree);
  // the DEMs are averaged to the step.
  CoarseGrid grid;
  grid.step_m = coarseStepM(params);
  grid.step_rad = coarseStepRad(params);
  const int fa = std::max(1, static_cast<int>(std::lround(grid.step_m / a.dem.cell_m)));
  const int fb = std::max(1, static_cast<int>(std::lround(grid.step_m / b.dem.cell_m)));
  const DemGrid coarse_a = fa > 1 ? coarsenDem(a.dem, fa) : a.dem;
  const DemGrid coarse_b = fb > 1 ? coarsenDem(b.dem, fb) : b.dem;
  const std::vector<Sample> coarse_samples = samplesOf(b, coarse_b, std::max(0.25, grid.step_m), params);
  const std::vector<Sample> samples = samplesOf(b, b.dem, params.sample_spacing_m, params);

  const Moments at_apriori = moments(a, a.dem, samples, apriori, params);
  const int min_samples = demcost::minSamples(a, b, params);
  if (at_apriori.n < min_samples) {
    out.overlap_cells = at_apriori.n;
    out.message = pair + ": their DEMs share " + std::to_string(at_apriori.n) +
                  " samples under the a-priori poses (at least " + std::to_string(min_samples) + " needed)";
    return out;
  }

  const int min_coarse = std::max(20, static_cast<int>(coarse_samples.size() / 20));
  coarseCosts(a, coarse_a, coarse_samples, apriori, params, min_coarse, grid);
  const Candidate best = bestOf(grid);
  if (!std::isfinite(best.cost)) {
    out.message = pair + ": no pose within the search window overlaps enough of the DEMs";
    return out;
  }
  const Candidate second_at = secondMinimum(grid, best, params);
  const double second = second_at.cost;
  out.cost_ratio = std::isfinite(second) && second > 0.0 ? best.cost / second : 0.0;
  out.coarse_rms_m = std::sqrt(best.cost);
  if (std::isfinite(second)) {
    out.relief_signal_m = std::sqrt(std::max(0.0, second - best.cost));
    out.second_offset_m = std::hypot(second_at.dx - best.dx, second_at.dy - best.dy);
    out.second_offset_deg = std::fabs(second_at.dh - best.dh) / kDegToRad;
  }

  const Candidate fine = fineSearch(a, b, apriori, params, grid, best, min_samples);
  Fit fit;
  fit.pose = shiftedPose(apriori, fine.dx, fine.dy, fine.dh);
  if (params.tilt_sigma_rad > 0.0) {
    fit.tilt_information = 1.0 / (params.tilt_sigma_rad * params.tilt_sigma_rad);
    fit.tilt_prior = apriori.tilt_rad;
    // The refinement starts from the tilt that levels the differences at the searched pose.
    const Eigen::Vector2d tilt =
        moments(a, a.dem, samples, fit.pose, params).levellingTilt(params.tilt_sigma_rad);
    fit.pose = turnedPose(fit.pose, Eigen::Vector3d(tilt.x(), tilt.y(), 0.0));
  }
  const Moments start = moments(a, a.dem, samples, fit.pose, params);
  if (start.n < min_samples) {
    out.message = pair + ": too few common DEM samples at the best pose";
    return out;
  }
  fit.pose.translation_m.z() -= start.mean();  // d = e_a + z: moving B down by d zeroes the mean

  // Gauss-Newton on the coarse DEMs (gradients over 0.2 m, a wide basin), then on the full ones (gradients
  // over two cells).
  // The tilt's prior is weighed against the data with the design effect of the differences at the start
  // (their spatial correlation: DemCost.hpp); the covariance takes it at the solution.
  const double start_factor =
      fit.solvesTilt() ? designEffect(a, samples, fit.pose, params, std::sqrt(start.variance())) : 1.0;
  bool converged = false;
  const RelativePose searched = fit.pose;
  const bool enough = gaussNewton(a, coarse_a, coarse_samples, coarse_a.cell_m, min_coarse, start_factor,
                                  params, fit, out, converged) &&
                      gaussNewton(a, a.dem, samples, 2.0 * a.dem.cell_m, min_samples, start_factor, params,
                                  fit, out, converged);
  out.drift_m = (fit.pose.translation_m - searched.translation_m).head<2>().norm();
  out.drift_deg = std::fabs(fit.pose.heading_rad - searched.heading_rad) / kDegToRad;
  if (!enough) {
    out.status = RegistrationStatus::kNotConverged;
    out.message = pair + ": too few common DEM samples after trimming: " + noiseAgainstRelief(out, params);
  } else {
    judgeSolution(a, samples, apriori, params, fit, converged, pair, out);
  }
  if (out.status != RegistrationStatus::kOk) tryOrthos(a, samples, b, params, out);
  return out;
}

}  // namespace areomap::traverse
