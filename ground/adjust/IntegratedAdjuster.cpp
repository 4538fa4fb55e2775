#include "ground/adjust/IntegratedAdjuster.hpp"

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <Eigen/SVD>
#include <chrono>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <vector>

#include "firmware_core/adjust/Constraints.hpp"
#include "firmware_core/adjust/FastAdjuster.hpp"

namespace areomap::ground {

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Unknown layout shared by both solvers: 6 per image, then 3 per solvable point (-1 = not an unknown).
struct Layout {
  std::vector<int> point_col;
  int cameras = 0;
  int unknowns = 0;
};

Layout makeLayout(const Network& net) {
  Layout l;
  l.cameras = 6 * net.imageCount();
  l.unknowns = l.cameras;
  l.point_col.assign(static_cast<size_t>(net.pointCount()), -1);
  for (int p = 0; p < net.pointCount(); ++p) {
    if (net.point(p).solvable) {
      l.point_col[p] = l.unknowns;
      l.unknowns += 3;
    }
  }
  return l;
}

bool usable(const Network& net, const NetObservation& o) {
  return !o.rejected && net.point(o.point).solvable;
}

// One shared fast adjuster (~15 MiB, static): its cost, redundancy and reduced camera system serve every
// integrated solution.
FastAdjuster& fastAdjuster() {
  static FastAdjuster adjuster;
  return adjuster;
}

double networkCost(const Network& net, double* rms_px) {
  return fastAdjuster().evaluateCost(net, rms_px);
}

double largestEoStepPx(const Network& net, const Eigen::VectorXd& delta, double range_m) {
  double step = 0.0;
  for (int i = 0; i < net.imageCount(); ++i) {
    const Vec3 dc = delta.segment<3>(6 * i);
    const double angle = delta.segment<3>(6 * i + 3).norm();
    step = std::max(step, eoPixelEquivalent(net.image(i).io.f_px, dc, angle, range_m));
  }
  return step;
}

// --- Ceres: a camera block is [C (3), M row-major (9)] on the manifold R^3 x SO(3), tangent [dC, delta].
// For a local Jacobian J (w.r.t. delta), the ambient one is J P^T / 2 with P = d vec(exp([delta]x) M) /
// d delta = [vec([e_k]x M)]: P's columns are orthogonal with squared norm 2, so (J P^T / 2) P = J.
using RotPlus = Eigen::Matrix<double, 9, 3, Eigen::RowMajor>;

RotPlus rotationPlusJacobian(const double* m_row_major) {
  const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> m(m_row_major);
  RotPlus p;
  for (int k = 0; k < 3; ++k) {
    const Mat3 dm = skew(Vec3::Unit(k)) * m;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) p(3 * r + c, k) = dm(r, c);
    }
  }
  return p;
}

void readCamera(const double* x, Vec3& c, Mat3& m) {
  c = Vec3(x[0], x[1], x[2]);
  m = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(x + 3);
}

class CameraManifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 12; }
  int TangentSize() const override { return 6; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override {
    Vec3 c;
    Mat3 m;
    readCamera(x, c, m);
    Vec6 d;
    for (int k = 0; k < 6; ++k) d(k) = delta[k];
    applyCameraUpdate(d, c, m);
    for (int k = 0; k < 3; ++k) x_plus_delta[k] = c(k);
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(x_plus_delta + 3) = m;
    return true;
  }
  bool PlusJacobian(const double* x, double* jacobian) const override {
    Eigen::Map<Eigen::Matrix<double, 12, 6, Eigen::RowMajor>> j(jacobian);
    j.setZero();
    j.block<3, 3>(0, 0).setIdentity();
    j.block<9, 3>(3, 3) = rotationPlusJacobian(x + 3);
    return true;
  }
  bool Minus(const double* y, const double* x, double* y_minus_x) const override {
    Vec3 cy, cx;
    Mat3 my, mx;
    readCamera(y, cy, my);
    readCamera(x, cx, mx);
    const Vec3 w = rotationVector(my * mx.transpose());
    for (int k = 0; k < 3; ++k) {
      y_minus_x[k] = cy(k) - cx(k);
      y_minus_x[3 + k] = w(k);
    }
    return true;
  }
  bool MinusJacobian(const double* x, double* jacobian) const override {
    Eigen::Map<Eigen::Matrix<double, 6, 12, Eigen::RowMajor>> j(jacobian);
    j.setZero();
    j.block<3, 3>(0, 0).setIdentity();
    j.block<3, 9>(3, 3) = rotationPlusJacobian(x + 3).transpose() / 2.0;
    return true;
  }
};

class ObservationCost final : public ceres::SizedCostFunction<2, 12, 3> {
 public:
  ObservationCost(const Network& net, int obs) : net_(net), obs_(obs) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const NetObservation& o = net_.observation(obs_);
    Vec3 c;
    Mat3 m;
    readCamera(parameters[0], c, m);
    const Vec3 point(parameters[1][0], parameters[1][1], parameters[1][2]);
    Vec2 r;
    Mat2x6 d_image;
    Mat2x3 d_point;
    if (!ok(observationRow(o, net_.image(o.image), c, m, point, r, &d_image, &d_point))) return false;
    // Ceres minimises |f|^2 / 2 with f = (predicted - observed) / sigma = -r.
    residuals[0] = -r(0);
    residuals[1] = -r(1);
    if (jacobians != nullptr) {
      if (jacobians[0] != nullptr) {
        Eigen::Map<Eigen::Matrix<double, 2, 12, Eigen::RowMajor>> j(jacobians[0]);
        j.block<2, 3>(0, 0) = d_image.block<2, 3>(0, 0);
        j.block<2, 9>(0, 3) =
            d_image.block<2, 3>(0, 3) * rotationPlusJacobian(parameters[0] + 3).transpose() / 2.0;
      }
      if (jacobians[1] != nullptr) {
        Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> j(jacobians[1]);
        j = d_point;
      }
    }
    return true;
  }

 private:
  const Network& net_;
  int obs_;
};

class PairConstraintCost final : public ceres::CostFunction {
 public:
  PairConstraintCost(const Network& net, int pair, int rows) : net_(net), pair_(pair) {
    set_num_residuals(rows);
    mutable_parameter_block_sizes()->push_back(12);
    if (net.pair(pair).right >= 0) mutable_parameter_block_sizes()->push_back(12);
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const bool has_right = net_.pair(pair_).right >= 0;
    Vec3 cl, cr;
    Mat3 ml, mr;
    readCamera(parameters[0], cl, ml);
    if (has_right) {
      readCamera(parameters[1], cr, mr);
    } else {
      cr = cl;
      mr = ml;
    }
    ConstraintRows rows;
    ConstraintJacobian jac;
    const int n = pairConstraintRows(net_, pair_, cl, ml, cr, mr, rows, jac);
    if (n != num_residuals()) return false;
    for (int i = 0; i < n; ++i) residuals[i] = rows(i);
    if (jacobians != nullptr) {
      for (int s = 0; s < (has_right ? 2 : 1); ++s) {
        if (jacobians[s] == nullptr) continue;
        Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 12, Eigen::RowMajor>> j(jacobians[s], n, 12);
        const RotPlus p = rotationPlusJacobian(parameters[s] + 3);
        j.leftCols<3>() = jac.block(0, 6 * s, n, 3);
        j.rightCols<9>() = jac.block(0, 6 * s + 3, n, 3) * p.transpose() / 2.0;
      }
    }
    return true;
  }

 private:
  const Network& net_;
  int pair_;
};

// The normal equations N x = b of every unknown (Layout) at the network's current state: the usable
// observations and every pair's constraint rows; `prior` (may be null) receives the part of N from rows that
// are no measurement (the datum prior, held rig constraints), which the covariance takes out of the
// sandwich (EoCovariance.hpp).
void assembleNormal(const Network& net, const Layout& layout, Eigen::MatrixXd& n, Eigen::VectorXd& b,
                    Eigen::MatrixXd* prior) {
  n.setZero();
  b.setZero();
  for (int k = 0; k < net.observationCount(); ++k) {
    const NetObservation& o = net.observation(k);
    if (!usable(net, o)) continue;
    const NetImage& im = net.image(o.image);
    Vec2 r;
    Mat2x6 ji;
    Mat2x3 jp;
    if (!ok(observationRow(o, im, im.centre_m, im.m, net.point(o.point).xyz_m, r, &ji, &jp))) continue;
    const int ci = 6 * o.image;
    const int cp = layout.point_col[o.point];
    n.block<6, 6>(ci, ci).noalias() += ji.transpose() * ji;
    n.block<6, 3>(ci, cp).noalias() += ji.transpose() * jp;
    n.block<3, 6>(cp, ci).noalias() += jp.transpose() * ji;
    n.block<3, 3>(cp, cp).noalias() += jp.transpose() * jp;
    b.segment<6>(ci).noalias() += ji.transpose() * r;
    b.segment<3>(cp).noalias() += jp.transpose() * r;
  }
  for (int p = 0; p < net.pairCount(); ++p) {
    ConstraintRows rows;
    ConstraintJacobian jac;
    if (currentPairConstraintRows(net, p, rows, jac) == 0) continue;
    const Mat12 nn = jac.transpose() * jac;
    const Vec12 bb = -(jac.transpose() * rows);
    const int idx[2] = {net.pair(p).left, net.pair(p).right};
    for (int a = 0; a < 2; ++a) {
      if (idx[a] < 0) continue;
      b.segment<6>(6 * idx[a]) += bb.segment<6>(6 * a);
      for (int c = 0; c < 2; ++c) {
        if (idx[c] < 0) continue;
        n.block<6, 6>(6 * idx[a], 6 * idx[c]) += nn.block<6, 6>(6 * a, 6 * c);
      }
    }
  }
  if (prior != nullptr) {
    prior->setZero(n.rows(), n.cols());
    for (int p = 0; p < net.pairCount(); ++p) {
      ConstraintJacobian fixed;
      const int rows = nonMeasurementRows(net, p, fixed);
      if (rows == 0) continue;
      const Mat12 nn = fixed.topRows(rows).transpose() * fixed.topRows(rows);
      const int idx[2] = {net.pair(p).left, net.pair(p).right};
      for (int a = 0; a < 2; ++a) {
        for (int c = 0; c < 2; ++c) {
          if (idx[a] >= 0 && idx[c] >= 0)
            prior->block<6, 6>(6 * idx[a], 6 * idx[c]) += nn.block<6, 6>(6 * a, 6 * c);
        }
      }
    }
  }
}

IntegratedResult svdOnce(Network& net, const IntegratedOptions& options) {
  const auto t0 = Clock::now();
  IntegratedResult result;
  result.method = "svd";
  const Layout layout = makeLayout(net);
  const int u = layout.unknowns;
  if (u == 0) throw std::runtime_error("integrated adjustment: no unknowns");
  result.unknowns = u;
  Eigen::MatrixXd n(u, u);
  Eigen::VectorXd b(u);
  for (int iter = 0; iter < options.max_iterations; ++iter) {
    assembleNormal(net, layout, n, b, nullptr);
    if (!n.allFinite() || !b.allFinite())
      throw std::runtime_error("integrated adjustment: non-finite normal matrix");
    // Minimum-norm least squares: singular values below the threshold are treated as zero.
    Eigen::BDCSVD<Eigen::MatrixXd> svd(n, Eigen::ComputeThinU | Eigen::ComputeThinV);
    svd.setThreshold(1e-12);
    const Eigen::VectorXd delta = svd.solve(b);
    for (int i = 0; i < net.imageCount(); ++i) {
      NetImage& im = net.image(i);
      applyCameraUpdate(delta.segment<6>(6 * i), im.centre_m, im.m);
    }
    for (int p = 0; p < net.pointCount(); ++p) {
      if (layout.point_col[p] >= 0) net.point(p).xyz_m += delta.segment<3>(layout.point_col[p]);
    }
    result.iterations = iter + 1;
    if (largestEoStepPx(net, delta, options.nominal_range_m) < options.eo_step_tolerance_px) {
      result.converged = true;
      break;
    }
  }
  result.cost = networkCost(net, &result.rms_px);
  result.seconds = secondsSince(t0);
  return result;
}

IntegratedResult ceresOnce(Network& net, const IntegratedOptions& options) {
  const auto t0 = Clock::now();
  IntegratedResult result;
  result.method = "ceres";
  const Layout layout = makeLayout(net);
  result.unknowns = layout.unknowns;
  std::vector<double> cameras(12 * static_cast<size_t>(net.imageCount()));
  std::vector<double> points(3 * static_cast<size_t>(net.pointCount()));
  for (int i = 0; i < net.imageCount(); ++i) {
    double* x = &cameras[12 * i];
    for (int k = 0; k < 3; ++k) x[k] = net.image(i).centre_m(k);
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(x + 3) = net.image(i).m;
  }
  for (int p = 0; p < net.pointCount(); ++p) {
    for (int k = 0; k < 3; ++k) points[3 * p + k] = net.point(p).xyz_m(k);
  }
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  CameraManifold manifold;
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (int k = 0; k < net.observationCount(); ++k) {
    const NetObservation& o = net.observation(k);
    if (!usable(net, o)) continue;
    problem.AddResidualBlock(new ObservationCost(net, k), nullptr, &cameras[12 * o.image],
                             &points[3 * o.point]);
  }
  for (int p = 0; p < net.pairCount(); ++p) {
    ConstraintRows rows;
    ConstraintJacobian jac;
    const int n = currentPairConstraintRows(net, p, rows, jac);
    if (n == 0) continue;
    if (net.pair(p).right >= 0) {
      problem.AddResidualBlock(new PairConstraintCost(net, p, n), nullptr, &cameras[12 * net.pair(p).left],
                               &cameras[12 * net.pair(p).right]);
    } else {
      problem.AddResidualBlock(new PairConstraintCost(net, p, n), nullptr, &cameras[12 * net.pair(p).left]);
    }
  }
  for (int i = 0; i < net.imageCount(); ++i) {
    if (!problem.HasParameterBlock(&cameras[12 * i])) continue;
    problem.SetManifold(&cameras[12 * i], &manifold);
    ordering->AddElementToGroup(&cameras[12 * i], 1);
  }
  for (int p = 0; p < net.pointCount(); ++p) {
    if (problem.HasParameterBlock(&points[3 * p])) ordering->AddElementToGroup(&points[3 * p], 0);
  }
  ceres::Solver::Options so;
  so.linear_solver_type = options.dense_schur ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
  so.linear_solver_ordering = ordering;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = 1e-14;
  so.gradient_tolerance = 1e-14;
  so.parameter_tolerance = 1e-12;
  so.num_threads = 1;
  so.minimizer_progress_to_stdout = options.verbose;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  for (int i = 0; i < net.imageCount(); ++i) {
    readCamera(&cameras[12 * i], net.image(i).centre_m, net.image(i).m);
  }
  for (int p = 0; p < net.pointCount(); ++p) {
    if (layout.point_col[p] >= 0)
      net.point(p).xyz_m = Vec3(points[3 * p], points[3 * p + 1], points[3 * p + 2]);
  }
  result.iterations = static_cast<int>(summary.iterations.size());
  result.converged = summary.IsSolutionUsable() && summary.termination_type == ceres::CONVERGENCE;
  result.message = summary.BriefReport();
  result.cost = networkCost(net, &result.rms_px);
  result.seconds = secondsSince(t0);
  return result;
}

// The SVD path's own EO covariance (EoCovariance.hpp defines it): sigma0^2 G (N - P) G over the cameras,
// with G = N^+ from the full normal matrix at the solution (the points among the unknowns, so that their
// uncertainty is carried, not held fixed), pseudo-inverted with the solver's own threshold, and P the part
// of N from rows that are no measurement.
void svdCovariance(Network& net, double sigma0) {
  const Layout layout = makeLayout(net);
  const int u = layout.unknowns;
  Eigen::MatrixXd n(u, u);
  Eigen::MatrixXd prior;
  Eigen::VectorXd b(u);
  assembleNormal(net, layout, n, b, &prior);
  Eigen::BDCSVD<Eigen::MatrixXd> svd(n, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  Eigen::VectorXd inverse = Eigen::VectorXd::Zero(sv.size());
  for (Eigen::Index k = 0; k < sv.size(); ++k) inverse(k) = sv(k) > 1e-12 * sv(0) ? 1.0 / sv(k) : 0.0;
  const Eigen::MatrixXd g_cameras =
      svd.matrixV().topRows(layout.cameras) * inverse.asDiagonal() * svd.matrixU().transpose();
  const Eigen::MatrixXd middle = n - prior;
  const Eigen::MatrixXd cov = sigma0 * sigma0 * (g_cameras * middle * g_cameras.transpose());
  for (int p = 0; p < net.pairCount(); ++p) {
    const int idx[2] = {net.pair(p).left, net.pair(p).right};
    Mat12 pair_cov = Mat12::Zero();
    for (int a = 0; a < 2; ++a) {
      for (int c = 0; c < 2; ++c) {
        if (idx[a] >= 0 && idx[c] >= 0)
          pair_cov.block<6, 6>(6 * a, 6 * c) = cov.block<6, 6>(6 * idx[a], 6 * idx[c]);
      }
    }
    setPairCovariance(net, p, pair_cov);
  }
}

// The precision of an integrated solution: sigma0 from its cost and the network's redundancy, and the EO
// covariance into every pair and image, from the full normal matrix (svd) or from the reduced camera system
// at the solution (ceres; EoCovariance.hpp: Ceres' own covariance would count the datum prior as a
// measurement).
void solutionPrecision(Network& net, IntegratedResult& result) {
  if (result.method == "svd") {
    int32_t active = 0;
    (void)fastAdjuster().evaluateCost(net, nullptr, &active);
    result.redundancy = networkRedundancy(net, active);
    result.sigma0 = result.redundancy > 0 ? std::sqrt(result.cost / result.redundancy) : 0.0;
    svdCovariance(net, result.sigma0);
    return;
  }
  FastAdjustResult fast;
  if (!ok(fastAdjuster().precisionOf(net, fast))) {
    throw std::runtime_error(std::string("integrated adjustment: the solution's network is not usable: ") +
                             statusName(fast.status));
  }
  result.redundancy = fast.redundancy;
  result.sigma0 = fast.sigma0;
  result.covariance_note = covarianceWarning(fast.covariance_status);
}

// Held rig sigmas (Network.hpp), as the fast adjuster applies them: solved again from where the solver
// stopped while a held constraint's misfit exceeds half its bound; iterations and seconds add up.
template <typename SolveOnce>
IntegratedResult withHeldRig(Network& net, SolveOnce solve_once) {
  IntegratedResult result = solve_once();
  for (int t = 0; t < kMaxRigTightenings && tightenHeldSigmas(net.rig, networkMisfit(net)); ++t) {
    IntegratedResult again = solve_once();
    again.iterations += result.iterations;
    again.seconds += result.seconds;
    again.rig_tightenings = result.rig_tightenings + 1;
    result = again;
  }
  solutionPrecision(net, result);
  return result;
}

}  // namespace

std::string covarianceWarning(Status status) {
  if (ok(status)) return "";
  return std::string("eo.csv sigmas are zero: the reduced camera system is ") + statusName(status) +
         " (the constraints do not make the network rigid).";
}

IntegratedResult adjustSvd(Network& net, const IntegratedOptions& options) {
  return withHeldRig(net, [&] { return svdOnce(net, options); });
}

IntegratedResult adjustCeres(Network& net, const IntegratedOptions& options) {
  return withHeldRig(net, [&] { return ceresOnce(net, options); });
}

}  // namespace areomap::ground
