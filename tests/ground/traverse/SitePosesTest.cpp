// The sites' poses (ground/traverse/SitePoses.hpp): the odometry's covariance chained leg by leg against
// the scatter of the chained poses over many draws of the legs' errors, and a camera model carried into
// the traverse frame against projecting the same point from both frames.
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "ground/traverse/SitePoses.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using namespace areomap::traverse;

TEST_GROUP(SitePoses){};

TEST(SitePoses, OdometryCovarianceMatchesTheChainedScatter) {
  Traverse t;
  t.sites.resize(5);
  t.sites[0].id = "site01";
  const double legs[4][3] = {{12.0, 3.0, 0.4}, {20.0, -5.0, -0.6}, {8.0, 1.0, 0.9}, {25.0, 0.0, -0.3}};
  for (int k = 1; k < 5; ++k) {
    OdometryLeg leg;
    leg.delta_m = Eigen::Vector3d(legs[k - 1][0], legs[k - 1][1], 0.1);
    leg.delta_heading_rad = legs[k - 1][2];
    leg.distance_m = leg.delta_m.norm();
    leg.sigma_m = Eigen::Vector3d(0.05, 0.05, 0.01) * leg.distance_m;
    leg.sigma_heading_rad = 2.0 * M_PI / 180.0;
    t.sites[k].id = "site0" + std::to_string(k + 1);
    t.sites[k].odometry = leg;
    SitePose prev = t.sites[k - 1].apriori;
    t.sites[k].apriori.position_m = prev.position_m + prev.rotation() * leg.delta_m;
    t.sites[k].apriori.heading_rad = prev.heading_rad + leg.delta_heading_rad;
  }
  const SitePoseSolution s = odometryPoses(t);
  // Monte Carlo: the legs as measured are the truth plus noise; chaining the noisy legs scatters the poses.
  std::mt19937 rng(3);
  std::normal_distribution<double> n01(0.0, 1.0);
  constexpr int kDraws = 20000;
  Eigen::Matrix4d scatter = Eigen::Matrix4d::Zero();
  for (int d = 0; d < kDraws; ++d) {
    SitePose p;
    for (int k = 1; k < 5; ++k) {
      const OdometryLeg& leg = *t.sites[k].odometry;
      const Eigen::Vector3d delta =
          leg.delta_m + Eigen::Vector3d(n01(rng), n01(rng), n01(rng)).cwiseProduct(leg.sigma_m);
      p.position_m += p.rotation() * delta;
      p.heading_rad += leg.delta_heading_rad + leg.sigma_heading_rad * n01(rng);
    }
    Eigen::Vector4d e;
    e << p.position_m - t.sites[4].apriori.position_m, p.heading_rad - t.sites[4].apriori.heading_rad;
    scatter += e * e.transpose() / kDraws;
  }
  const Eigen::Matrix4d& c = s.sites[4].covariance;
  std::printf(
      "\n  last site: sigma x %.3f / %.3f m, y %.3f / %.3f m, heading %.4f / %.4f rad (chained / scatter)\n",
      std::sqrt(c(0, 0)), std::sqrt(scatter(0, 0)), std::sqrt(c(1, 1)), std::sqrt(scatter(1, 1)),
      std::sqrt(c(3, 3)), std::sqrt(scatter(3, 3)));
  for (int i = 0; i < 4; ++i) DOUBLES_EQUAL(1.0, std::sqrt(scatter(i, i) / c(i, i)), 0.05);
  DOUBLES_EQUAL(c(0, 1) / std::sqrt(c(0, 0) * c(1, 1)),
                scatter(0, 1) / std::sqrt(scatter(0, 0) * scatter(1, 1)), 0.05);
  CHECK_TRUE(s.sites[0].source == PoseSource::kFirstSite);
  CHECK_TRUE(s.sites[4].source == PoseSource::kOdometry);
}

TEST_GROUP(TraverseModels){};

TEST(TraverseModels, ProjectTheSamePointFromBothFrames) {
  CameraModel m;
  m.type = CameraType::kCahvor;
  m.c = Vec3(0.1, -0.05, -1.5);
  m.a = Vec3(0.9, 0.1, 0.42).normalized();
  const Vec3 h0 = Vec3(0.0, 1.0, 0.0) - m.a * m.a.y();
  const Vec3 v0 = m.a.cross(h0.normalized());
  m.h = 1200.0 * h0.normalized() + 512.0 * m.a;
  m.v = 1200.0 * v0 + 512.0 * m.a;
  m.o = (m.a + Vec3(0.0, 0.01, 0.0)).normalized();
  m.r = Vec3(0.0, 0.003, -0.001);
  m.width = m.height = 1024;
  SitePose pose;
  pose.position_m = Eigen::Vector3d(12.0, -3.0, 0.2);
  pose.heading_rad = -0.4;
  const CameraModel t = toTraverseFrame(m, pose);
  double worst = 0.0;
  for (const Vec3& p : {Vec3(5.0, 0.5, 0.0), Vec3(3.0, -1.0, 0.1), Vec3(8.0, 2.0, -0.3)}) {
    Vec2 a, b;
    CHECK_TRUE(ok(project(m, p, a)));
    CHECK_TRUE(ok(project(t, pose.toTraverse(p), b)));
    worst = std::max(worst, (a - b).norm());
  }
  CHECK_TRUE(worst < 1e-9);
}
