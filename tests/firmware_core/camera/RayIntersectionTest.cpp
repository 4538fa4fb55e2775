#include <cmath>
#include <cstdio>
#include <random>

#include "firmware_core/camera/RayIntersection.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/camera/TestModels.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

// Status comparisons that print both names on failure.
#define CHECK_STATUS(expected, actual) STRCMP_EQUAL(statusName(expected), statusName(actual))

namespace {

Vec3 randomUnit(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Vec3(n(rng), n(rng), n(rng)).normalized();
}

// A unit vector perpendicular to `u`.
Vec3 perpendicularUnit(const Vec3& u, std::mt19937& rng) {
  for (;;) {
    const Vec3 r = randomUnit(rng);
    const Vec3 p = r - r.dot(u) * u;
    if (p.norm() > 0.1) return p.normalized();
  }
}

// The model moved rigidly: rotated by `r` about its centre, the centre shifted by `shift_m`.
CameraModel movedBy(const CameraModel& m, const Vec3& rotation_vector, const Vec3& shift_m) {
  return movedModel(m, rotationFromVector(rotation_vector), m.c + shift_m);
}

// A point the model sees at `range_m`, through a pixel drawn uniformly from the inner 80 % of the image.
bool pointInView(const CameraModel& m, double range_m, std::mt19937& rng, Vec3& point) {
  std::uniform_real_distribution<double> u(0.1, 0.9);
  Vec3 o, d;
  if (!ok(unproject(m, Vec2(u(rng) * m.width, u(rng) * m.height), o, d))) return false;
  point = o + range_m * d;
  return true;
}

double squaredReprojection(const CameraModel* const* models, const Vec2* pixels, int32_t n, const Vec3& p) {
  double sum = 0.0;
  for (int32_t i = 0; i < n; ++i) {
    Vec2 uv;
    if (!ok(project(*models[i], p, uv))) return INFINITY;
    sum += (uv - pixels[i]).squaredNorm();
  }
  return sum;
}

}  // namespace

TEST_GROUP(RayIntersection){};

// Two skew rays built around a known common perpendicular (p1 -> p2, both rays perpendicular to it): the
// closest approach is that segment, over 8 seeds of random geometry (ranges 1-50 m, gaps 1 mm - 0.5 m).
TEST(RayIntersection, ClosestApproachIsTheCommonPerpendicular) {
  for (uint32_t seed = 1; seed <= 8; ++seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> range(1.0, 50.0), gap(0.001, 0.5), pos(-20.0, 20.0);
    const Vec3 p1(pos(rng), pos(rng), pos(rng));
    const Vec3 u = randomUnit(rng);
    const double g = gap(rng);
    const Vec3 p2 = p1 + g * u;
    const Vec3 d1 = perpendicularUnit(u, rng), d2 = perpendicularUnit(u, rng);
    if (1.0 - d1.dot(d2) * d1.dot(d2) < 1e-3) continue;  // nearly parallel draws say nothing here
    const double t1 = range(rng), t2 = range(rng);
    Vec3 mid;
    double miss = 0.0;
    CHECK_STATUS(Status::kOk,
                 closestApproach(p1 - t1 * d1, d1, p2 - t2 * d2, d2, kMinMidpointRaySin2, mid, miss));
    CHECK((mid - 0.5 * (p1 + p2)).norm() < 1e-9);
    DOUBLES_EQUAL(g, miss, 1e-9);
    // The same segment behind the first origin.
    CHECK_STATUS(Status::kBehindCamera,
                 closestApproach(p1 + t1 * d1, d1, p2 - t2 * d2, d2, kMinMidpointRaySin2, mid, miss));
  }
  // Parallel: the squared sine of the angle against the threshold (1 µrad for the midpoint).
  const Vec3 o1(0.0, 0.0, 0.0), o2(0.0, 0.2, 0.0), d(1.0, 0.0, 0.0);
  const Vec3 d_half_urad = Vec3(1.0, 0.5e-6, 0.0).normalized(),
             d_two_urad = Vec3(1.0, -2e-6, 0.0).normalized();
  Vec3 mid;
  double miss = 0.0;
  CHECK_STATUS(Status::kDegenerate, closestApproach(o1, d, o2, d, kMinMidpointRaySin2, mid, miss));
  CHECK_STATUS(Status::kDegenerate, closestApproach(o1, d, o2, d_half_urad, kMinMidpointRaySin2, mid, miss));
  CHECK_STATUS(Status::kOk, closestApproach(o1, d, o2, d_two_urad, kMinMidpointRaySin2, mid, miss));
  DOUBLES_EQUAL(0.2 / 2e-6, mid.x(), 100.0);  // 100 km out, to 0.1 % (1 - b^2 ~ 4e-12 loses ~11 digits)
}

// Points seen by a stereo pair of every synthetic model (CAHVOR, CAHVORE; base 0.2-0.5 m, toe-in up to
// 1 deg), 2-50 m away: the midpoint of the two pixels' rays is the point.
TEST(RayIntersection, MidpointOfTwoPixelsRecoversThePoint) {
  double worst = 0.0;
  int32_t points = 0;
  for (const test::NamedModel& nm : test::syntheticModels()) {
    for (uint32_t seed = 1; seed <= 4; ++seed) {
      std::mt19937 rng(seed);
      std::uniform_real_distribution<double> base(0.2, 0.5), toe(-0.017, 0.017), range(2.0, 50.0);
      const Vec3 h_dir = (nm.model.h - nm.model.a.dot(nm.model.h) * nm.model.a).normalized();
      const CameraModel right = movedBy(nm.model, Vec3(toe(rng), toe(rng), toe(rng)), base(rng) * h_dir);
      for (int32_t k = 0; k < 20; ++k) {
        Vec3 truth, p;
        Vec2 l, r;
        if (!pointInView(nm.model, range(rng), rng, truth)) continue;
        if (!ok(project(nm.model, truth, l)) || !ok(project(right, truth, r))) continue;
        double miss = 1.0;
        CHECK_STATUS(Status::kOk, triangulateMidpoint(nm.model, right, l, r, p, miss));
        worst = std::fmax(worst, (p - truth).norm() / (truth - nm.model.c).norm());
        CHECK(miss < 1e-6);
        ++points;
      }
    }
  }
  std::printf("\nmidpoint: %d points, worst error %.2e of the range\n", points, worst);
  CHECK(points >= 400);
  CHECK(worst < 1e-9);
  // The same pixel in the same camera: parallel rays.
  const CameraModel m = test::navcamLike();
  Vec3 p;
  double miss = 0.0;
  CHECK_STATUS(Status::kDegenerate,
               triangulateMidpoint(m, m, Vec2(300.0, 400.0), Vec2(300.0, 400.0), p, miss));
}

// The least-squares point of two rays (eigen-decomposition of the summed projectors) is the midpoint of
// their closest approach (closed form): two independent computations, 8 seeds. Rays through one point give
// that point for 2-8 rays.
TEST(RayIntersection, LeastSquaresPointOfRaysAgreesWithTheClosestApproach) {
  for (uint32_t seed = 1; seed <= 8; ++seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> pos(-5.0, 5.0), range(2.0, 40.0);
    const Vec3 truth(pos(rng) + 20.0, pos(rng), pos(rng));
    Vec3 origins[kMaxIntersectionViews], dirs[kMaxIntersectionViews];
    for (int32_t i = 0; i < kMaxIntersectionViews; ++i) {
      origins[i] = truth - range(rng) * randomUnit(rng);
      dirs[i] = (truth - origins[i]).normalized();
    }
    // Two skew rays: the second origin moved off its ray.
    Vec3 o2 = origins[1] + 0.05 * perpendicularUnit(dirs[1], rng);
    Vec3 skew_origins[2] = {origins[0], o2};
    Vec3 least, mid;
    double miss = 0.0;
    if (!ok(closestApproach(origins[0], dirs[0], o2, dirs[1], kMinMidpointRaySin2, mid, miss))) continue;
    CHECK_STATUS(Status::kOk, intersectRays(skew_origins, dirs, 2, least));
    CHECK((least - mid).norm() < 1e-9);
    for (int32_t n = 2; n <= kMaxIntersectionViews; ++n) {
      Vec3 p;
      CHECK_STATUS(Status::kOk, intersectRays(origins, dirs, n, p));
      CHECK((p - truth).norm() < 1e-9);
    }
  }
  const Vec3 o[2] = {Vec3(0, 0, 0), Vec3(0, 0.2, 0)}, d[2] = {Vec3(1, 0, 0), Vec3(1, 0, 0)};
  Vec3 p;
  CHECK_STATUS(Status::kDegenerate, intersectRays(o, d, 2, p));
  CHECK_STATUS(Status::kDegenerate, intersectRays(o, d, 1, p));
}

// Up to 8 views of a point (every synthetic model, moved about a mast): with exact pixels the point comes
// back; with 0.3 px noise the result is a minimum of the summed squared reprojection error (no step of
// 0.1 mm along any axis lowers it), its per-view residuals are the distances the test measures itself, and
// the call makes no heap allocation.
TEST(RayIntersection, PixelIntersectionMinimisesTheReprojectionError) {
  double worst_exact = 0.0;
  int32_t cases = 0;
  uint64_t heap = 0;
  for (const test::NamedModel& nm : test::syntheticModels()) {
    for (uint32_t seed = 1; seed <= 3; ++seed) {
      std::mt19937 rng(seed);
      std::uniform_real_distribution<double> turn(-0.06, 0.06), shift(-0.3, 0.3), range(3.0, 30.0);
      std::normal_distribution<double> noise(0.0, 0.3);
      CameraModel views[kMaxIntersectionViews];
      const CameraModel* models[kMaxIntersectionViews];
      views[0] = nm.model;
      for (int32_t i = 1; i < kMaxIntersectionViews; ++i) {
        views[i] = movedBy(nm.model, Vec3(turn(rng), turn(rng), turn(rng)),
                           Vec3(shift(rng), shift(rng), shift(rng)));
      }
      for (int32_t i = 0; i < kMaxIntersectionViews; ++i) models[i] = &views[i];
      Vec3 truth;
      if (!pointInView(nm.model, range(rng), rng, truth)) continue;
      Vec2 exact[kMaxIntersectionViews], noisy[kMaxIntersectionViews];
      int32_t n = 0;
      for (int32_t i = 0; i < kMaxIntersectionViews; ++i) {
        if (!ok(project(views[i], truth, exact[n]))) break;
        noisy[n] = exact[n] + Vec2(noise(rng), noise(rng));
        ++n;
      }
      if (n < 3) continue;
      PixelIntersection x;
      CHECK_STATUS(Status::kOk, intersectPixels(models, exact, n, x));
      worst_exact = std::fmax(worst_exact, (x.point_m - truth).norm());
      HeapAllocationScope scope;
      const Status s = intersectPixels(models, noisy, n, x);
      heap += scope.allocations();
      CHECK_STATUS(Status::kOk, s);
      const double at = squaredReprojection(models, noisy, n, x.point_m);
      for (int32_t k = 0; k < 3; ++k) {
        for (const double step : {-1e-4, 1e-4}) {
          Vec3 q = x.point_m;
          q(k) += step;
          CHECK(squaredReprojection(models, noisy, n, q) >= at * (1.0 - 1e-12));
        }
      }
      double sum = 0.0;
      for (int32_t i = 0; i < n; ++i) {
        Vec2 uv;
        CHECK_STATUS(Status::kOk, project(views[i], x.point_m, uv));
        DOUBLES_EQUAL((uv - noisy[i]).norm(), x.residual_px[i], 1e-9);
        sum += (uv - noisy[i]).squaredNorm();
      }
      DOUBLES_EQUAL(std::sqrt(sum / (2.0 * n)), x.rms_px, 1e-9);
      CHECK(x.normal.determinant() > 0.0);
      ++cases;
    }
  }
  std::printf("\npixel intersection: %d cases, worst error with exact pixels %.2e m\n", cases, worst_exact);
  CHECK(cases >= 12);
  CHECK(worst_exact < 1e-9);
  CHECK_EQUAL(0u, heap);
  const CameraModel m = test::navcamLike();
  const CameraModel* one[1] = {&m};
  const Vec2 px[1] = {Vec2(500.0, 500.0)};
  PixelIntersection x;
  CHECK_STATUS(Status::kInvalidArgument, intersectPixels(one, px, 1, x));
}
