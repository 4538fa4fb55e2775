// CoarseDemRegistration on a synthetic two-site scene: one terrain (a few hills and a ridge), each site's
// coarse DEM made from points of it within 25 m of the site in its own frame; B's true pose in A is known,
// the a-priori one off by ~1 m and 3 degrees, and the registration must find the true one. A flat terrain
// must not register (no relief to fix the pose).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>

#include "firmware_core/dem/CoarseDemRegistration.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

constexpr double kRegTestPi = 3.14159265358979323846;

// Terrain elevation up (m) at traverse (x, y): hills of 1-2 m over 5-10 m and a ridge, nothing periodic.
double terrainUp(double x, double y) {
  return 1.5 * std::exp(-((x - 8.0) * (x - 8.0) + (y - 4.0) * (y - 4.0)) / 30.0) +
         1.0 * std::exp(-((x - 16.0) * (x - 16.0) + (y + 6.0) * (y + 6.0)) / 18.0) -
         0.8 * std::exp(-((x - 3.0) * (x - 3.0) + (y + 9.0) * (y + 9.0)) / 40.0) + 0.05 * x +
         0.6 * std::tanh((y - 0.3 * x - 10.0) / 3.0);
}

// The DEM of a site at pose (p, heading) in the traverse frame, from points on a 0.25 m grid within 25 m.
void siteDem(const LevelledPose& traverse_from_site, double relief, CoarseDem& dem) {
  dem.reset(Vec3::Zero());
  const Mat3 r = traverse_from_site.rotation();
  for (double x = -25.0; x <= 25.0; x += 0.25) {
    for (double y = -25.0; y <= 25.0; y += 0.25) {
      if (x * x + y * y > 625.0) continue;
      const Vec3 t = r * Vec3(x, y, 0.0) + traverse_from_site.translation_m;
      const double up = relief * terrainUp(t.x(), t.y());
      // Site frame Z down: X_traverse = R X_site + t, so Z_site = -up - t_z (levelled frames).
      (void)dem.addPoint(Vec3(x, y, -up - traverse_from_site.translation_m.z()));
    }
  }
  (void)dem.finish();
}

}  // namespace

TEST_GROUP(CoarseDemRegistration){};

TEST(CoarseDemRegistration, RecoversAKnownOffsetOfTwoSites) {
  std::unique_ptr<CoarseDem> a(new CoarseDem), b(new CoarseDem);
  std::unique_ptr<CoarseDemRegistration> reg(new CoarseDemRegistration);
  LevelledPose truth;  // A is the traverse frame; B is 14 m on, turned 25 degrees
  truth.translation_m = Vec3(12.0, 7.0, 0.0);
  truth.heading_rad = 25.0 * kRegTestPi / 180.0;
  siteDem(LevelledPose{}, 1.0, *a);
  siteDem(truth, 1.0, *b);
  LevelledPose apriori = truth;
  apriori.translation_m += Vec3(0.9, -0.7, 0.3);
  apriori.heading_rad += 3.0 * kRegTestPi / 180.0;
  DemRegistrationParams params;
  params.search_m = 3.0;
  params.search_deg = 6.0;
  const auto t0 = std::chrono::steady_clock::now();
  const DemRegistrationResult r = reg->run(*a, *b, apriori, params);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("\ncoarse DEM registration: %d samples, %d iterations, %.3f s (+-3 m, +-6 deg)\n",
              static_cast<int>(r.overlap), static_cast<int>(r.iterations), seconds);
  CHECK_EQUAL(static_cast<int>(DemRegistrationStatus::kOk), static_cast<int>(r.status));
  // B's origin in A is the translation; its height: the origin of each site frame lies on its own datum, so
  // the true z offset is truth.z (0).
  DOUBLES_EQUAL(truth.translation_m.x(), r.a_from_b.translation_m.x(), 0.1);
  DOUBLES_EQUAL(truth.translation_m.y(), r.a_from_b.translation_m.y(), 0.1);
  DOUBLES_EQUAL(truth.translation_m.z(), r.a_from_b.translation_m.z(), 0.05);
  DOUBLES_EQUAL(truth.heading_rad, r.a_from_b.heading_rad, 0.3 * kRegTestPi / 180.0);
  CHECK_TRUE(r.sigma[0] > 0.0 && r.sigma[0] < 0.1);
}

TEST(CoarseDemRegistration, FlatGroundDoesNotRegister) {
  std::unique_ptr<CoarseDem> a(new CoarseDem), b(new CoarseDem);
  std::unique_ptr<CoarseDemRegistration> reg(new CoarseDemRegistration);
  LevelledPose truth;
  truth.translation_m = Vec3(12.0, 7.0, 0.0);
  siteDem(LevelledPose{}, 0.0, *a);
  siteDem(truth, 0.0, *b);
  LevelledPose apriori = truth;
  apriori.translation_m += Vec3(0.9, -0.7, 0.0);
  const DemRegistrationResult r = reg->run(*a, *b, apriori, DemRegistrationParams{});
  CHECK_TRUE(r.status != DemRegistrationStatus::kOk);
  DOUBLES_EQUAL(apriori.translation_m.x(), r.a_from_b.translation_m.x(), 1e-12);  // the a-priori pose kept
}
