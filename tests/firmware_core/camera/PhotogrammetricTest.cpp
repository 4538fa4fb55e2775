#include <cmath>

#include "firmware_core/camera/Photogrammetric.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/camera/TestModels.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using areomap::HeapAllocationScope;
using areomap::test::relErr;

namespace {

InteriorOrientation navcamIo() {
  InteriorOrientation io;
  io.f_px = 1236.0;
  io.x0_px = 511.5;
  io.y0_px = 511.5;
  io.width = 1024;
  io.height = 1024;
  return io;
}

}  // namespace

TEST_GROUP(Photogrammetric){};

TEST(Photogrammetric, OpkRoundTripsThroughTheRotationMatrix) {
  const double angles[][3] = {{0.3, -0.7, 2.9}, {-1.2, 0.2, -0.4}, {2.0, 1.3, 0.1}, {-3.0, -1.5, 3.1}};
  for (const auto& a : angles) {
    const Mat3 m = rotationFromOpk(a[0], a[1], a[2]);
    DOUBLES_EQUAL(1.0, m.determinant(), 1e-12);
    CHECK((m * m.transpose() - Mat3::Identity()).norm() < 1e-12);
    double o, p, k;
    opkFromRotation(m, o, p, k);
    CHECK((rotationFromOpk(o, p, k) - m).norm() < 1e-12);
    // Wolf & Dewitt element formulas, written out independently.
    DOUBLES_EQUAL(std::sin(a[1]), m(2, 0), 1e-15);
    DOUBLES_EQUAL(-std::sin(a[0]) * std::cos(a[1]), m(2, 1), 1e-15);
    DOUBLES_EQUAL(std::cos(a[0]) * std::cos(a[1]), m(2, 2), 1e-15);
    DOUBLES_EQUAL(std::cos(a[1]) * std::cos(a[2]), m(0, 0), 1e-15);
    DOUBLES_EQUAL(-std::cos(a[1]) * std::sin(a[2]), m(1, 0), 1e-15);
  }
}

TEST(Photogrammetric, OpkJacobiansMatchCentralDifferences) {
  const InteriorOrientation io = navcamIo();
  ExteriorOrientation eo;
  eo.centre_m = Vec3(0.3, -0.2, -1.5);
  eo.omega_rad = 1.4;
  eo.phi_rad = -0.35;
  eo.kappa_rad = 0.2;
  const Mat3 m = rotationFromOpk(eo.omega_rad, eo.phi_rad, eo.kappa_rad);
  // A point 6 m in front of the camera, off-axis.
  const Vec3 point = eo.centre_m + m.transpose() * Vec3(0.9, -1.3, -6.0);
  Vec2 px;
  Mat2x6 d_eo;
  Mat2x3 d_point;
  CHECK(collinearityOpk(io, eo, point, px, &d_eo, &d_point) == Status::kOk);
  const double h_lin = 1e-5, h_ang = 1e-7;
  for (int k = 0; k < 6; ++k) {
    ExteriorOrientation plus = eo, minus = eo;
    double* pp[6] = {&plus.centre_m.x(), &plus.centre_m.y(), &plus.centre_m.z(), &plus.omega_rad,
                     &plus.phi_rad, &plus.kappa_rad};
    double* pm[6] = {&minus.centre_m.x(), &minus.centre_m.y(), &minus.centre_m.z(), &minus.omega_rad,
                     &minus.phi_rad, &minus.kappa_rad};
    const double h = k < 3 ? h_lin : h_ang;
    *pp[k] += h;
    *pm[k] -= h;
    Vec2 a, b;
    CHECK(collinearityOpk(io, plus, point, a) == Status::kOk);
    CHECK(collinearityOpk(io, minus, point, b) == Status::kOk);
    const Vec2 numeric = (a - b) / (2.0 * h);
    CHECK(relErr(numeric.x(), d_eo(0, k)) < 1e-6);
    CHECK(relErr(numeric.y(), d_eo(1, k)) < 1e-6);
  }
  for (int k = 0; k < 3; ++k) {
    Vec3 dp = Vec3::Zero();
    dp(k) = h_lin;
    Vec2 a, b;
    CHECK(collinearityOpk(io, eo, point + dp, a) == Status::kOk);
    CHECK(collinearityOpk(io, eo, point - dp, b) == Status::kOk);
    const Vec2 numeric = (a - b) / (2.0 * h_lin);
    CHECK(relErr(numeric.x(), d_point(0, k)) < 1e-6);
    CHECK(relErr(numeric.y(), d_point(1, k)) < 1e-6);
  }
}

TEST(Photogrammetric, LocalRotationJacobianMatchesCentralDifferences) {
  const InteriorOrientation io = navcamIo();
  const Mat3 m = rotationFromOpk(-0.4, 1.2, 2.5);
  const Vec3 c(1.0, 2.0, -1.4);
  const Vec3 point = c + m.transpose() * Vec3(-2.0, 0.5, -9.0);
  Vec2 px;
  Mat2x3 d_c, d_r, d_p;
  CHECK(collinearity(io, c, m, point, px, &d_c, &d_r, &d_p) == Status::kOk);
  const double h = 1e-7;
  for (int k = 0; k < 3; ++k) {
    Vec3 w = Vec3::Zero();
    w(k) = h;
    Vec2 a, b;
    CHECK(collinearity(io, c, rotationFromVector(w) * m, point, a) == Status::kOk);
    CHECK(collinearity(io, c, rotationFromVector(-w) * m, point, b) == Status::kOk);
    const Vec2 numeric = (a - b) / (2.0 * h);
    CHECK(relErr(numeric.x(), d_r(0, k)) < 1e-6);
    CHECK(relErr(numeric.y(), d_r(1, k)) < 1e-6);
  }
  CHECK((d_c + d_p).norm() < 1e-12);
}

TEST(Photogrammetric, PointBehindTheCameraIsFlagged) {
  const InteriorOrientation io = navcamIo();
  const Mat3 m = Mat3::Identity();
  Vec2 px;
  // The camera looks along -z: a point at +z is behind it.
  CHECK(collinearity(io, Vec3::Zero(), m, Vec3(0.0, 0.0, 3.0), px) == Status::kBehindCamera);
  CHECK(collinearity(io, Vec3::Zero(), m, Vec3(0.0, 0.0, -3.0), px) == Status::kOk);
  DOUBLES_EQUAL(io.x0_px, px.x(), 1e-12);
  DOUBLES_EQUAL(io.y0_px, px.y(), 1e-12);
  // Image right is camera +x, image up is camera +y (line decreases).
  CHECK(collinearity(io, Vec3::Zero(), m, Vec3(0.1, 0.1, -3.0), px) == Status::kOk);
  CHECK(px.x() > io.x0_px);
  CHECK(px.y() < io.y0_px);
}

TEST(Photogrammetric, DistortionInverseRoundTrips) {
  LensDistortion d;
  d.cx_px = 520.0;
  d.cy_px = 500.0;
  d.norm_px = 1236.0;
  d.k1 = -0.05;
  d.k2 = 0.01;
  d.p1 = 1e-4;
  d.p2 = -2e-4;
  d.b1 = 3e-4;
  for (double x = 0.0; x <= 1023.0; x += 255.75) {
    for (double y = 0.0; y <= 1023.0; y += 255.75) {
      Vec2 distorted;
      CHECK(distortPixel(d, Vec2(x, y), distorted) == Status::kOk);
      const Vec2 back = undistortPixel(d, distorted);
      CHECK((back - Vec2(x, y)).norm() < 1e-8);
    }
  }
}

TEST(Photogrammetric, MakesNoHeapAllocations) {
  const InteriorOrientation io = navcamIo();
  ExteriorOrientation eo;
  eo.omega_rad = 0.2;
  eo.phi_rad = 0.3;
  eo.kappa_rad = 0.1;
  HeapAllocationScope scope;
  Vec2 px;
  Mat2x6 d_eo;
  Mat2x3 d_point;
  double sum = 0.0;
  for (int i = 0; i < 100; ++i) {
    const Vec3 p = rotationFromOpk(0.2, 0.3, 0.1).transpose() * Vec3(0.01 * i, 0.2, -5.0);
    if (collinearityOpk(io, eo, p, px, &d_eo, &d_point) == Status::kOk) sum += px.x() + d_eo(0, 3);
  }
  CHECK(sum != 0.0);
  CHECK_EQUAL(0u, scope.allocations());
}
