// An independent check of SitePoseAdjuster: the same traverse problem (the adjuster's sites, cameras,
// observations and odometry legs) solved the way a ground tool without the rover's constraints would — every
// unknown (free site poses and points) in one dense Gauss-Newton system (Eigen dynamic matrices), its
// Jacobian by central differences of residuals written here from the definitions (no analytic Jacobian, no
// Schur elimination, no block Cholesky of the rover code) — must reach the same minimum and the same pose
// covariance.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include <Eigen/Dense>

#include "firmware_core/adjust/SitePoseAdjuster.hpp"
#include "tests/firmware_core/adjust/SyntheticTraverse.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

SitePoseAdjuster g_dense_adjuster;

// The problem as the dense solver sees it: site k >= 1 free, pose (p_k, exp([w_k]x) Q_ref_k), and points.
struct DenseProblem {
  const SitePoseAdjuster* adj = nullptr;
  std::vector<Mat3> q_ref;      // per site
  std::vector<int32_t> points;  // adjuster point index per dense point (solvable ones)
  int32_t sites = 0;
  int32_t unknowns() const { return 6 * (sites - 1) + 3 * static_cast<int32_t>(points.size()); }
};

TraverseFromSite poseOf(const DenseProblem& pb, const Eigen::VectorXd& x, int32_t k) {
  TraverseFromSite p;
  if (k == 0) return pb.adj->site(0).pose;
  p.position_m = x.segment<3>(6 * (k - 1));
  p.rotation = rotationFromVector(x.segment<3>(6 * (k - 1) + 3)) * pb.q_ref[k];
  return p;
}

Vec3 logOf(const Mat3& r) {
  const Eigen::AngleAxisd aa(r);
  return aa.axis() * aa.angle();
}

// Whitened residuals from the definitions: collinearity of every usable observation, then every leg.
Eigen::VectorXd residuals(const DenseProblem& pb, const Eigen::VectorXd& x) {
  std::vector<double> r;
  const int32_t point_base = 6 * (pb.sites - 1);
  for (size_t i = 0; i < pb.points.size(); ++i) {
    const CrossSitePoint& pt = pb.adj->point(pb.points[i]);
    const Vec3 xyz = x.segment<3>(point_base + 3 * static_cast<int32_t>(i));
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const CrossSiteObservation& o = pb.adj->observation(pt.obs[k]);
      if (o.rejected) continue;
      const SiteCamera& c = pb.adj->camera(o.camera);
      const TraverseFromSite pose = poseOf(pb, x, c.site);
      const Vec3 centre = pose.position_m + pose.rotation * c.centre_in_site_m;
      const Mat3 m = c.m_site * pose.rotation.transpose();
      const Vec3 d = m * (xyz - centre);
      r.push_back((c.io.x0_px - c.io.f_px * d.x() / d.z() - o.ideal_px.x()) / o.sigma_px);
      r.push_back((c.io.y0_px + c.io.f_px * d.y() / d.z() - o.ideal_px.y()) / o.sigma_px);
    }
  }
  for (int32_t k = 1; k < pb.sites; ++k) {
    const TraverseFromSite a = poseOf(pb, x, k - 1);
    const TraverseFromSite b = poseOf(pb, x, k);
    const LegMeasurement& leg = pb.adj->site(k).leg;
    const Vec3 dp = a.rotation.transpose() * (b.position_m - a.position_m) - leg.delta_position_m;
    const Vec3 dr = logOf(leg.delta_rotation.transpose() * a.rotation.transpose() * b.rotation);
    for (int32_t i = 0; i < 3; ++i) r.push_back(dp(i) / leg.sigma_position_m(i));
    for (int32_t i = 0; i < 3; ++i) r.push_back(dr(i) / leg.sigma_rotation_rad(i));
  }
  return Eigen::Map<Eigen::VectorXd>(r.data(), static_cast<Eigen::Index>(r.size()));
}

Eigen::MatrixXd numericJacobian(const DenseProblem& pb, const Eigen::VectorXd& x, Eigen::Index rows) {
  Eigen::MatrixXd j(rows, x.size());
  for (Eigen::Index c = 0; c < x.size(); ++c) {
    const double h = 1e-6 * std::max(1.0, std::fabs(x(c)));
    Eigen::VectorXd xp = x, xm = x;
    xp(c) += h;
    xm(c) -= h;
    j.col(c) = (residuals(pb, xp) - residuals(pb, xm)) / (2.0 * h);
  }
  return j;
}

// Rotation parameters re-centred: Q_ref = the current rotation, w = 0 (the adjuster's local update).
void recentre(DenseProblem& pb, Eigen::VectorXd& x) {
  for (int32_t k = 1; k < pb.sites; ++k) {
    pb.q_ref[k] = poseOf(pb, x, k).rotation;
    x.segment<3>(6 * (k - 1) + 3).setZero();
  }
}

}  // namespace

TEST_GROUP(SitePoseDenseCheck){};

TEST(SitePoseDenseCheck, DenseGaussNewtonReachesTheSameMinimumAndCovariance) {
  test::TraverseConfig cfg;
  cfg.sites = 5;
  cfg.points_per_leg = 20;
  cfg.seed = 71;
  const test::TraversePlan plan = test::makeTraversePlan(cfg);
  test::TraverseLoad load;
  CHECK(test::loadTraverse(plan, 0, cfg.sites, true, g_dense_adjuster, load));
  SitePoseResult r;
  CHECK(ok(g_dense_adjuster.adjust(SitePoseOptions{}, r)));
  CHECK(r.converged);

  // Dense start: the a-priori poses and the true points (the minimum, not the path, is compared).
  DenseProblem pb;
  pb.adj = &g_dense_adjuster;
  pb.sites = g_dense_adjuster.siteCount();
  pb.q_ref.resize(pb.sites);
  for (int32_t p = 0; p < g_dense_adjuster.pointCount(); ++p) {
    if (g_dense_adjuster.point(p).solvable) pb.points.push_back(p);
  }
  Eigen::VectorXd x(pb.unknowns());
  for (int32_t k = 1; k < pb.sites; ++k) {
    x.segment<3>(6 * (k - 1)) = g_dense_adjuster.site(k).apriori.position_m;
    x.segment<3>(6 * (k - 1) + 3).setZero();
    pb.q_ref[k] = g_dense_adjuster.site(k).apriori.rotation;
  }
  std::vector<int32_t> plan_point(g_dense_adjuster.pointCount(), -1);
  for (size_t i = 0; i < plan.points.size(); ++i) {
    if (load.point[i] >= 0) plan_point[load.point[i]] = static_cast<int32_t>(i);
  }
  for (size_t i = 0; i < pb.points.size(); ++i)
    x.segment<3>(6 * (pb.sites - 1) + 3 * static_cast<int32_t>(i)) = plan.points[plan_point[pb.points[i]]];

  double cost = residuals(pb, x).squaredNorm();
  int32_t iterations = 0;
  for (; iterations < 30; ++iterations) {
    recentre(pb, x);
    const Eigen::VectorXd e = residuals(pb, x);
    const Eigen::MatrixXd j = numericJacobian(pb, x, e.size());
    const Eigen::MatrixXd n = j.transpose() * j;
    const Eigen::VectorXd step = n.ldlt().solve(-(j.transpose() * e));
    double t = 1.0;
    Eigen::VectorXd next = x + step;
    while (residuals(pb, next).squaredNorm() > cost && t > 1e-6) {
      t *= 0.5;
      next = x + t * step;
    }
    const double next_cost = residuals(pb, next).squaredNorm();
    x = next;
    const double decrease = cost - next_cost;
    cost = next_cost;
    if (step.norm() * t < 1e-9 || decrease < 1e-12 * cost) break;
  }
  recentre(pb, x);
  const Eigen::VectorXd e = residuals(pb, x);
  const Eigen::MatrixXd j = numericJacobian(pb, x, e.size());
  const Eigen::MatrixXd cov_unscaled = (j.transpose() * j).inverse();
  const Eigen::Index redundancy = e.size() - x.size();
  const double sigma0 = std::sqrt(e.squaredNorm() / static_cast<double>(redundancy));
  const double scale = std::max(1.0, sigma0);

  double pose_m = 0.0, pose_rad = 0.0, sigma_rel = 0.0, cov_rel = 0.0;
  for (int32_t k = 1; k < pb.sites; ++k) {
    const SiteState& s = g_dense_adjuster.site(k);
    const TraverseFromSite dense = poseOf(pb, x, k);
    pose_m = std::max(pose_m, (dense.position_m - s.pose.position_m).norm());
    pose_rad = std::max(pose_rad, logOf(dense.rotation * s.pose.rotation.transpose()).norm());
    const Mat6 c = cov_unscaled.block<6, 6>(6 * (k - 1), 6 * (k - 1)) * (scale * scale);
    for (int32_t a = 0; a < 6; ++a) {
      sigma_rel = std::max(sigma_rel, std::fabs(std::sqrt(c(a, a)) - s.sigma(a)) / std::sqrt(c(a, a)));
      for (int32_t b = 0; b < 6; ++b)
        cov_rel = std::max(cov_rel, std::fabs(c(a, b) - s.covariance(a, b)) / std::sqrt(c(a, a) * c(b, b)));
    }
  }
  std::printf(
      "\n  dense check: %lld unknowns %lld residuals, %d Gauss-Newton steps; cost dense %.9g rover %.9g; "
      "redundancy %lld / %d, sigma0 %.4f / %.4f; pose difference %.2e m %.2e rad; sigma difference "
      "%.2e relative, covariance %.2e of sigma_a sigma_b\n",
      static_cast<long long>(x.size()), static_cast<long long>(e.size()), iterations + 1, e.squaredNorm(),
      r.cost, static_cast<long long>(redundancy), r.redundancy, sigma0, r.sigma0, pose_m, pose_rad, sigma_rel,
      cov_rel);
  CHECK(std::fabs(e.squaredNorm() - r.cost) < 1e-6 * r.cost);
  CHECK_EQUAL(static_cast<int32_t>(redundancy), r.redundancy);
  CHECK(pose_m < 1e-6);
  CHECK(pose_rad < 1e-8);
  CHECK(sigma_rel < 1e-4);
  CHECK(cov_rel < 1e-4);
}
