#include "ground/adjust/SitePoseCeres.hpp"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <chrono>
#include <cmath>
#include <memory>

namespace areomap::ground {

namespace {

using Clock = std::chrono::steady_clock;

bool freeSite(const SitePoseProblem& p, int32_t site) {
  return site > 0 && site >= p.first_free_site;
}

// The firmware's leg rule (SitePoseAdjuster legActive): the leg into site k counts when k or k - 1 is free.
bool legActive(const SitePoseProblem& p, int32_t site) {
  return site > 0 && (freeSite(p, site) || freeSite(p, site - 1));
}

// Per point: in the solve (placed, >= 2 rays not rejected, one of them from a free site); the firmware's
// solvable && in_window.
std::vector<bool> pointsInSolve(const SitePoseProblem& p) {
  std::vector<int32_t> rays(p.points.size(), 0);
  std::vector<bool> seen_free(p.points.size(), false);
  for (const SitePoseObservation& o : p.observations) {
    if (o.rejected) continue;
    ++rays[o.point];
    if (freeSite(p, p.cameras[o.camera].site)) seen_free[o.point] = true;
  }
  std::vector<bool> in(p.points.size(), false);
  for (size_t i = 0; i < p.points.size(); ++i) in[i] = p.placed[i] && rays[i] >= 2 && seen_free[i];
  return in;
}

// An ideal-pixel observation of a point by a camera of a site: the point into the site frame, Q^T (X - p),
// then the camera's collinearity there (Photogrammetric.hpp collinearity: d = M_s (X_s - C_s),
// sample = x0 - f d_x / d_z, line = y0 + f d_y / d_z), whitened.
struct ObservationResidual {
  ObservationResidual(const SiteCamera& camera, const Vec2& ideal_px, double sigma_px)
      : camera_(camera), ideal_px_(ideal_px), sigma_px_(sigma_px) {}

  template <typename T>
  bool operator()(const T* position, const T* rotation, const T* point, T* residual) const {
    const T v[3] = {point[0] - position[0], point[1] - position[1], point[2] - position[2]};
    const T inverse[4] = {rotation[0], -rotation[1], -rotation[2], -rotation[3]};
    T in_site[3];
    ceres::UnitQuaternionRotatePoint(inverse, v, in_site);
    T d[3];
    for (int i = 0; i < 3; ++i) {
      d[i] = T(0.0);
      for (int j = 0; j < 3; ++j) d[i] += camera_.m_site(i, j) * (in_site[j] - camera_.centre_in_site_m(j));
    }
    if (!(d[2] < T(0.0))) return false;  // behind the camera: Ceres rejects the step
    const double f = camera_.io.f_px;
    residual[0] = (camera_.io.x0_px - f * d[0] / d[2] - ideal_px_.x()) / sigma_px_;
    residual[1] = (camera_.io.y0_px + f * d[1] / d[2] - ideal_px_.y()) / sigma_px_;
    return true;
  }

  SiteCamera camera_;
  Vec2 ideal_px_;
  double sigma_px_;
};

// An odometry leg from site a to site b: [Q_a^T (p_b - p_a) - d] / sigma_pos and
// log(Q_ab_measured^T Q_a^T Q_b) / sigma_rot (SitePoseRows.hpp).
struct LegResidual {
  explicit LegResidual(const LegMeasurement& leg) : leg_(leg) {
    const Eigen::Quaterniond q(leg.delta_rotation);
    measured_inverse_[0] = q.w();
    measured_inverse_[1] = -q.x();
    measured_inverse_[2] = -q.y();
    measured_inverse_[3] = -q.z();
  }

  template <typename T>
  bool operator()(const T* pa, const T* qa, const T* pb, const T* qb, T* residual) const {
    const T v[3] = {pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]};
    const T qa_inverse[4] = {qa[0], -qa[1], -qa[2], -qa[3]};
    T d[3];
    ceres::UnitQuaternionRotatePoint(qa_inverse, v, d);
    for (int i = 0; i < 3; ++i) residual[i] = (d[i] - leg_.delta_position_m(i)) / leg_.sigma_position_m(i);
    T relative[4];
    ceres::QuaternionProduct(qa_inverse, qb, relative);
    const T measured_inverse[4] = {T(measured_inverse_[0]), T(measured_inverse_[1]), T(measured_inverse_[2]),
                                   T(measured_inverse_[3])};
    T error[4];
    ceres::QuaternionProduct(measured_inverse, relative, error);
    T angle_axis[3];
    ceres::QuaternionToAngleAxis(error, angle_axis);
    for (int i = 0; i < 3; ++i) residual[3 + i] = angle_axis[i] / leg_.sigma_rotation_rad(i);
    return true;
  }

  LegMeasurement leg_;
  double measured_inverse_[4];
};

}  // namespace

SitePoseCeresResult solveSitePosesCeres(SitePoseProblem& problem, const SitePoseCeresOptions& options) {
  const auto t0 = Clock::now();
  SitePoseCeresResult result;
  const int32_t sites = static_cast<int32_t>(problem.poses.size());
  // Per site [p (3), q (w, x, y, z)], per point xyz.
  std::vector<double> positions(3 * problem.poses.size());
  std::vector<double> rotations(4 * problem.poses.size());
  std::vector<double> points(3 * problem.points.size());
  for (int32_t k = 0; k < sites; ++k) {
    const Eigen::Quaterniond q(problem.poses[k].rotation);
    for (int i = 0; i < 3; ++i) positions[3 * k + i] = problem.poses[k].position_m(i);
    rotations[4 * k] = q.w();
    rotations[4 * k + 1] = q.x();
    rotations[4 * k + 2] = q.y();
    rotations[4 * k + 3] = q.z();
  }
  for (size_t i = 0; i < problem.points.size(); ++i) {
    for (int j = 0; j < 3; ++j) points[3 * i + j] = problem.points[i](j);
  }
  const std::vector<bool> in_solve = pointsInSolve(problem);

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem ceres_problem(problem_options);
  ceres::QuaternionManifold manifold;
  ceres::HuberLoss huber(options.huber_sigma > 0.0 ? options.huber_sigma : 1.0);
  ceres::LossFunction* loss = options.huber_sigma > 0.0 ? &huber : nullptr;
  for (const SitePoseObservation& o : problem.observations) {
    if (o.rejected || !in_solve[o.point]) continue;
    const int32_t site = problem.cameras[o.camera].site;
    ceres_problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<ObservationResidual, 2, 3, 4, 3>(
            new ObservationResidual(problem.cameras[o.camera], o.ideal_px, o.sigma_px)),
        loss, &positions[3 * site], &rotations[4 * site], &points[3 * o.point]);
    ++result.observations;
  }
  for (int32_t k = 1; k < sites; ++k) {
    if (!legActive(problem, k)) continue;
    ceres_problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<LegResidual, 6, 3, 4, 3, 4>(new LegResidual(problem.legs[k])),
        nullptr, &positions[3 * (k - 1)], &rotations[4 * (k - 1)], &positions[3 * k], &rotations[4 * k]);
  }
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (int32_t k = 0; k < sites; ++k) {
    if (!ceres_problem.HasParameterBlock(&positions[3 * k])) continue;
    ceres_problem.SetManifold(&rotations[4 * k], &manifold);
    if (freeSite(problem, k)) {
      ++result.free_sites;
    } else {
      ceres_problem.SetParameterBlockConstant(&positions[3 * k]);
      ceres_problem.SetParameterBlockConstant(&rotations[4 * k]);
    }
    ordering->AddElementToGroup(&positions[3 * k], 1);
    ordering->AddElementToGroup(&rotations[4 * k], 1);
  }
  for (size_t i = 0; i < problem.points.size(); ++i) {
    if (!in_solve[i]) continue;
    ordering->AddElementToGroup(&points[3 * i], 0);
    ++result.points;
  }
  ceres::Solver::Options so;
  so.linear_solver_type = options.dense_schur ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
  so.linear_solver_ordering = ordering;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = options.function_tolerance;
  so.gradient_tolerance = options.gradient_tolerance;
  so.parameter_tolerance = options.parameter_tolerance;
  so.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &ceres_problem, &summary);
  for (int32_t k = 0; k < sites; ++k) {
    problem.poses[k].position_m = Vec3(positions[3 * k], positions[3 * k + 1], positions[3 * k + 2]);
    problem.poses[k].rotation =
        Eigen::Quaterniond(rotations[4 * k], rotations[4 * k + 1], rotations[4 * k + 2], rotations[4 * k + 3])
            .normalized()
            .toRotationMatrix();
  }
  for (size_t i = 0; i < problem.points.size(); ++i) {
    if (in_solve[i]) problem.points[i] = Vec3(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
  }
  // Iteration 0 (the start) counts as a successful step in Ceres' summary.
  result.iterations = static_cast<int32_t>(summary.iterations.size()) - 1;
  result.converged = summary.IsSolutionUsable() && summary.termination_type == ceres::CONVERGENCE;
  result.initial_cost = 2.0 * summary.initial_cost;
  result.cost = 2.0 * summary.final_cost;
  result.termination = ceres::TerminationTypeToString(summary.termination_type);
  result.message = summary.BriefReport();
  result.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return result;
}

double sitePoseRowsCost(const SitePoseProblem& problem, double huber_sigma, double* rms_px) {
  const std::vector<bool> in_solve = pointsInSolve(problem);
  double total = 0.0, pixel_sq = 0.0;
  int32_t n = 0;
  for (const SitePoseObservation& o : problem.observations) {
    if (o.rejected || !in_solve[o.point]) continue;
    const SiteCamera& camera = problem.cameras[o.camera];
    Vec2 e;
    if (!ok(crossSiteObservationRow(problem.poses[camera.site], camera, problem.points[o.point], o.ideal_px,
                                    o.sigma_px, e, nullptr, nullptr))) {
      return HUGE_VAL;
    }
    const double sq = e.squaredNorm();
    const double norm = std::sqrt(sq);
    total +=
        huber_sigma > 0.0 && norm > huber_sigma ? 2.0 * huber_sigma * norm - huber_sigma * huber_sigma : sq;
    pixel_sq += sq * o.sigma_px * o.sigma_px;
    ++n;
  }
  for (int32_t k = 1; k < static_cast<int32_t>(problem.poses.size()); ++k) {
    if (!legActive(problem, k)) continue;
    Vec6 e;
    odometryRows(problem.poses[k - 1], problem.poses[k], problem.legs[k], e, nullptr, nullptr);
    total += e.squaredNorm();
  }
  if (rms_px != nullptr) *rms_px = n > 0 ? std::sqrt(pixel_sq / (2.0 * n)) : 0.0;
  return total;
}

}  // namespace areomap::ground
