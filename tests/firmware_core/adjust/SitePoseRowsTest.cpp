// SitePoseRows (firmware_core/adjust/SitePoseRows.hpp): the analytic Jacobians of the cross-site
// observation row and the odometry leg against central numeric differences, at random site poses.
#include <algorithm>
#include <cmath>
#include <random>

#include "firmware_core/adjust/SitePoseRows.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

constexpr double kPi = 3.14159265358979323846;

TraverseFromSite randomPose(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  TraverseFromSite p;
  p.position_m = Vec3(20.0 * u(rng), 20.0 * u(rng), u(rng));
  p.rotation = rotationFromVector(Vec3(0.1 * u(rng), 0.1 * u(rng), kPi * u(rng)));
  return p;
}

TraverseFromSite perturbed(const TraverseFromSite& pose, int32_t index, double h) {
  Vec6 d = Vec6::Zero();
  d(index) = h;
  TraverseFromSite p = pose;
  applySiteUpdate(d, p);
  return p;
}

}  // namespace

TEST_GROUP(SitePoseRows){};

TEST(SitePoseRows, ObservationJacobiansMatchNumericDifferences) {
  std::mt19937 rng(7);
  double worst = 0.0;
  for (int32_t trial = 0; trial < 20; ++trial) {
    const TraverseFromSite pose = randomPose(rng);
    SiteCamera cam;
    cam.site = 0;
    cam.io.f_px = 1236.0;
    cam.io.x0_px = 511.5;
    cam.io.y0_px = 511.5;
    cam.centre_in_site_m = Vec3(0.3, -0.1, -1.5);
    cam.m_site = rotationFromVector(Vec3(0.2 * trial, 1.0, -0.4));
    Vec3 centre;
    Mat3 m;
    cameraInTraverse(pose, cam, centre, m);
    // A point 8 m in front of the camera, off its axis.
    const Vec3 point = centre + m.transpose() * Vec3(1.5, -0.8, -8.0);
    const Vec2 observed(400.0, 600.0);
    Vec2 e;
    Mat2x6 j_pose;
    Mat2x3 j_point;
    CHECK(ok(crossSiteObservationRow(pose, cam, point, observed, 0.3, e, &j_pose, &j_point)));
    const double h = 1e-6;
    for (int32_t i = 0; i < 6; ++i) {
      Vec2 ep, em;
      CHECK(ok(
          crossSiteObservationRow(perturbed(pose, i, h), cam, point, observed, 0.3, ep, nullptr, nullptr)));
      CHECK(ok(
          crossSiteObservationRow(perturbed(pose, i, -h), cam, point, observed, 0.3, em, nullptr, nullptr)));
      const Vec2 numeric = (ep - em) / (2.0 * h);
      worst = std::max(worst, (numeric - j_pose.col(i)).norm() / std::max(1.0, numeric.norm()));
    }
    for (int32_t i = 0; i < 3; ++i) {
      Vec3 dx = Vec3::Zero();
      dx(i) = h;
      Vec2 ep, em;
      CHECK(ok(crossSiteObservationRow(pose, cam, point + dx, observed, 0.3, ep, nullptr, nullptr)));
      CHECK(ok(crossSiteObservationRow(pose, cam, point - dx, observed, 0.3, em, nullptr, nullptr)));
      const Vec2 numeric = (ep - em) / (2.0 * h);
      worst = std::max(worst, (numeric - j_point.col(i)).norm() / std::max(1.0, numeric.norm()));
    }
  }
  std::printf("\n  observation rows: largest relative Jacobian difference %.2e\n", worst);
  CHECK(worst < 1e-6);
}

TEST(SitePoseRows, OdometryJacobiansMatchNumericDifferences) {
  std::mt19937 rng(11);
  double worst = 0.0;
  for (int32_t trial = 0; trial < 20; ++trial) {
    const TraverseFromSite a = randomPose(rng);
    const TraverseFromSite b = randomPose(rng);
    LegMeasurement leg;
    Vec3 d;
    Mat3 r;
    relativePose(a, b, d, r);
    // A large misfit (0.4 rad, metres), where the right-Jacobian inverse matters.
    leg.delta_position_m = d + Vec3(1.0, -2.0, 0.5);
    leg.delta_rotation = r * rotationFromVector(Vec3(0.2, -0.3, 0.1));
    leg.sigma_position_m = Vec3(0.5, 0.7, 0.1);
    leg.sigma_rotation_rad = Vec3(0.004, 0.005, 0.03);
    Vec6 e;
    Mat6 ja, jb;
    odometryRows(a, b, leg, e, &ja, &jb);
    const double h = 1e-6;
    for (int32_t i = 0; i < 6; ++i) {
      Vec6 ep, em;
      odometryRows(perturbed(a, i, h), b, leg, ep, nullptr, nullptr);
      odometryRows(perturbed(a, i, -h), b, leg, em, nullptr, nullptr);
      Vec6 numeric = (ep - em) / (2.0 * h);
      worst = std::max(worst, (numeric - ja.col(i)).norm() / std::max(1.0, numeric.norm()));
      odometryRows(a, perturbed(b, i, h), leg, ep, nullptr, nullptr);
      odometryRows(a, perturbed(b, i, -h), leg, em, nullptr, nullptr);
      numeric = (ep - em) / (2.0 * h);
      worst = std::max(worst, (numeric - jb.col(i)).norm() / std::max(1.0, numeric.norm()));
    }
  }
  std::printf("\n  odometry rows: largest relative Jacobian difference %.2e\n", worst);
  CHECK(worst < 1e-6);
}
