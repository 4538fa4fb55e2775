// The height gradient of a two-ray intersection with respect to the pair's EO (ground/products/
// CameraHeightError.hpp) against numeric differences: each of the 12 unknowns moved by +-h (the adjusters'
// local update, Constraints.hpp applyCameraUpdate), the point intersected again from the same ideal
// pixels by Gauss-Newton on the pixel residuals, the height difference over 2h.
#include <cmath>
#include <cstdio>

#include "firmware_core/adjust/Constraints.hpp"
#include "firmware_core/camera/Photogrammetric.hpp"
#include "ground/products/CameraHeightError.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

NetImage netCamera(const Vec3& centre, double pan_rad, double tilt_rad) {
  NetImage im;
  im.io.f_px = 1200.0;
  im.io.x0_px = 512.0;
  im.io.y0_px = 512.0;
  im.io.width = im.io.height = 1024;
  // Camera looking north (+X), tilted down, panned east: rows of M are the camera x, y, z axes (site
  // frame), the camera looking along -z.
  const Vec3 look(std::cos(tilt_rad) * std::cos(pan_rad), std::cos(tilt_rad) * std::sin(pan_rad),
                  std::sin(tilt_rad));  // Z down: positive tilt looks down
  const Vec3 right = Vec3(0, 0, 1).cross(look).normalized();
  const Vec3 up = right.cross(look).normalized();
  im.m.row(0) = right.transpose();
  im.m.row(1) = up.transpose();
  im.m.row(2) = (-look).transpose();
  im.centre_m = centre;
  return im;
}

// The point whose projections are `pl`, `pr` in the two cameras, from `start` (Gauss-Newton).
Vec3 intersect(const NetImage& l, const NetImage& r, const Vec2& pl, const Vec2& pr, Vec3 x) {
  for (int it = 0; it < 20; ++it) {
    Eigen::Matrix<double, 4, 3> a;
    Eigen::Vector4d res;
    const NetImage* cams[2] = {&l, &r};
    const Vec2* obs[2] = {&pl, &pr};
    for (int s = 0; s < 2; ++s) {
      Vec2 p;
      Mat2x3 dp;
      CHECK_TRUE(ok(collinearity(cams[s]->io, cams[s]->centre_m, cams[s]->m, x, p, nullptr, nullptr, &dp)));
      a.middleRows<2>(2 * s) = dp;
      res.segment<2>(2 * s) = *obs[s] - p;
    }
    x += (a.transpose() * a).ldlt().solve(a.transpose() * res);
  }
  return x;
}

}  // namespace

TEST_GROUP(CameraHeightError){};

TEST(CameraHeightError, GradientMatchesNumericDifferences) {
  const Vec3 gimbal(0.0, 0.0, -1.5);
  double worst = 0.0;
  for (double range : {3.0, 8.0, 15.0}) {
    for (double pan : {0.0, 0.7}) {
      const NetImage l = netCamera(gimbal + Vec3(0.0, -0.1, 0.0), pan, 0.3);
      NetImage r = netCamera(gimbal + Vec3(0.0, 0.1, 0.0), pan, 0.3);
      applyCameraUpdate((Vec6() << 0.0, 0.0, 0.0, 0.001, -0.002, 0.0005).finished(), r.centre_m, r.m);
      const Vec3 point(range * std::cos(pan), range * std::sin(pan), 0.05);  // on the ground (Z down)
      Vec2 pl, pr;
      CHECK_TRUE(ok(collinearity(l.io, l.centre_m, l.m, point, pl)));
      CHECK_TRUE(ok(collinearity(r.io, r.centre_m, r.m, point, pr)));
      double g[12];
      CHECK_TRUE(products::heightGradient(l, r, point, g));
      for (int d = 0; d < 12; ++d) {
        const double h = d % 6 < 3 ? 1e-5 : 1e-7;
        double height[2];
        for (int sgn = 0; sgn < 2; ++sgn) {
          NetImage lm = l, rm = r;
          Vec6 step = Vec6::Zero();
          step(d % 6) = sgn == 0 ? h : -h;
          if (d < 6)
            applyCameraUpdate(step, lm.centre_m, lm.m);
          else
            applyCameraUpdate(step, rm.centre_m, rm.m);
          height[sgn] = -intersect(lm, rm, pl, pr, point).z();
        }
        const double numeric = (height[0] - height[1]) / (2.0 * h);
        const double scale = std::max(std::fabs(numeric), d % 6 < 3 ? 1e-3 : range * 1e-2);
        worst = std::max(worst, std::fabs(g[d] - numeric) / scale);
      }
    }
  }
  std::printf("\n  largest relative difference of the height gradient from numeric differences: %.2e\n",
              worst);
  CHECK_TRUE(worst < 1e-4);
}

TEST(CameraHeightError, NoGradientBehindACamera) {
  const NetImage l = netCamera(Vec3(0.0, -0.1, -1.5), 0.0, 0.3);
  const NetImage r = netCamera(Vec3(0.0, 0.1, -1.5), 0.0, 0.3);
  double g[12];
  CHECK_FALSE(products::heightGradient(l, r, Vec3(-5.0, 0.0, 0.0), g));
}
