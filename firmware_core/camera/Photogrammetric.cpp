#include "firmware_core/camera/Photogrammetric.hpp"

#include <cmath>

#include "firmware_core/base/Capacities.hpp"

namespace areomap {
namespace {

void axisRotations(double omega, double phi, double kappa, Mat3& r_omega, Mat3& r_phi, Mat3& r_kappa) {
  const double so = std::sin(omega), co = std::cos(omega);
  const double sp = std::sin(phi), cp = std::cos(phi);
  const double sk = std::sin(kappa), ck = std::cos(kappa);
  r_omega << 1.0, 0.0, 0.0, 0.0, co, so, 0.0, -so, co;
  r_phi << cp, 0.0, -sp, 0.0, 1.0, 0.0, sp, 0.0, cp;
  r_kappa << ck, sk, 0.0, -sk, ck, 0.0, 0.0, 0.0, 1.0;
}

// d(sample, line)/d(camera-frame vector d) for x = -f dx/dz, y = -f dy/dz, sample = x0 + x, line = y0 - y.
Mat2x3 pixelWrtCameraVector(double f, const Vec3& d) {
  const double iz = 1.0 / d.z();
  Mat2x3 j;
  j << -f * iz, 0.0, f * d.x() * iz * iz, 0.0, f * iz, -f * d.y() * iz * iz;
  return j;
}

}  // namespace

Mat3 rotationFromOpk(double omega_rad, double phi_rad, double kappa_rad) {
  Mat3 r_omega, r_phi, r_kappa;
  axisRotations(omega_rad, phi_rad, kappa_rad, r_omega, r_phi, r_kappa);
  Mat3 m;
  m.noalias() = r_kappa * r_phi * r_omega;
  return m;
}

void opkFromRotation(const Mat3& m, double& omega_rad, double& phi_rad, double& kappa_rad) {
  const double s = std::fmax(-1.0, std::fmin(1.0, m(2, 0)));
  phi_rad = std::asin(s);
  if (std::fabs(s) < 1.0 - 1e-12) {
    omega_rad = std::atan2(-m(2, 1), m(2, 2));
    kappa_rad = std::atan2(-m(1, 0), m(0, 0));
  } else {
    // Gimbal lock: only omega +- kappa is defined; put it all in omega.
    kappa_rad = 0.0;
    omega_rad = std::atan2(m(0, 1), m(1, 1));
  }
}

void rotationDerivatives(double omega_rad, double phi_rad, double kappa_rad, Mat3& d_omega, Mat3& d_phi,
                         Mat3& d_kappa) {
  Mat3 r_omega, r_phi, r_kappa;
  axisRotations(omega_rad, phi_rad, kappa_rad, r_omega, r_phi, r_kappa);
  const double so = std::sin(omega_rad), co = std::cos(omega_rad);
  const double sp = std::sin(phi_rad), cp = std::cos(phi_rad);
  const double sk = std::sin(kappa_rad), ck = std::cos(kappa_rad);
  Mat3 dr_omega, dr_phi, dr_kappa;
  dr_omega << 0.0, 0.0, 0.0, 0.0, -so, co, 0.0, -co, -so;
  dr_phi << -sp, 0.0, -cp, 0.0, 0.0, 0.0, cp, 0.0, -sp;
  dr_kappa << -sk, ck, 0.0, -ck, -sk, 0.0, 0.0, 0.0, 0.0;
  d_omega.noalias() = r_kappa * r_phi * dr_omega;
  d_phi.noalias() = r_kappa * dr_phi * r_omega;
  d_kappa.noalias() = dr_kappa * r_phi * r_omega;
}

Status collinearity(const InteriorOrientation& io, const Vec3& centre, const Mat3& m, const Vec3& point,
                    Vec2& pixel, Mat2x3* d_centre, Mat2x3* d_rotation, Mat2x3* d_point) {
  const Vec3 delta = point - centre;
  Vec3 d;
  d.noalias() = m * delta;
  if (!(d.z() < 0.0)) {
    return Status::kBehindCamera;
  }
  const double f = io.f_px;
  pixel.x() = io.x0_px - f * d.x() / d.z();
  pixel.y() = io.y0_px + f * d.y() / d.z();
  if (d_centre == nullptr && d_rotation == nullptr && d_point == nullptr) {
    return Status::kOk;
  }
  const Mat2x3 j_d = pixelWrtCameraVector(f, d);
  if (d_point != nullptr) {
    d_point->noalias() = j_d * m;
  }
  if (d_centre != nullptr) {
    d_centre->noalias() = -(j_d * m);
  }
  if (d_rotation != nullptr) {
    // d' = exp([delta]x) d ~ d + delta x d = d - [d]x delta
    d_rotation->noalias() = -(j_d * skew(d));
  }
  return Status::kOk;
}

Status collinearityOpk(const InteriorOrientation& io, const ExteriorOrientation& eo, const Vec3& point,
                       Vec2& pixel, Mat2x6* d_eo, Mat2x3* d_point) {
  const Mat3 m = rotationFromOpk(eo.omega_rad, eo.phi_rad, eo.kappa_rad);
  Mat2x3 d_centre;
  const Status status =
      collinearity(io, eo.centre_m, m, point, pixel, d_eo != nullptr ? &d_centre : nullptr, nullptr, d_point);
  if (status != Status::kOk || d_eo == nullptr) {
    return status;
  }
  Mat3 dm_omega, dm_phi, dm_kappa;
  rotationDerivatives(eo.omega_rad, eo.phi_rad, eo.kappa_rad, dm_omega, dm_phi, dm_kappa);
  const Vec3 delta = point - eo.centre_m;
  Vec3 d;
  d.noalias() = m * delta;
  const Mat2x3 j_d = pixelWrtCameraVector(io.f_px, d);
  d_eo->block<2, 3>(0, 0) = d_centre;
  Vec3 dd;
  dd.noalias() = dm_omega * delta;
  d_eo->col(3).noalias() = j_d * dd;
  dd.noalias() = dm_phi * delta;
  d_eo->col(4).noalias() = j_d * dd;
  dd.noalias() = dm_kappa * delta;
  d_eo->col(5).noalias() = j_d * dd;
  return Status::kOk;
}

Vec2 undistortPixel(const LensDistortion& d, const Vec2& distorted) {
  const double x = (distorted.x() - d.cx_px) / d.norm_px;
  const double y = (distorted.y() - d.cy_px) / d.norm_px;
  const double r2 = x * x + y * y;
  const double tilt = (d.s1 + d.q1 * r2) * x + (d.s2 + d.q2 * r2) * y;
  const double radial = d.k0 + r2 * (d.k1 + r2 * (d.k2 + r2 * (d.k3 + r2 * (d.k4 + r2 * d.k5)))) + tilt;
  const double dx = x * radial + d.p1 * (r2 + 2.0 * x * x) + 2.0 * d.p2 * x * y + d.b1 * x + d.b2 * y + d.t1;
  const double dy = y * radial + d.p2 * (r2 + 2.0 * y * y) + 2.0 * d.p1 * x * y + d.t2;
  return Vec2(distorted.x() + dx * d.norm_px, distorted.y() + dy * d.norm_px);
}

Status distortPixel(const LensDistortion& d, const Vec2& ideal, Vec2& distorted) {
  // Newton on undistortPixel(distorted) = ideal with a forward-difference 2x2 Jacobian: converges where
  // the plain fixed point (distorted = ideal - delta) does not, as for the large corrections of a
  // fisheye-like model fitted to a pinhole (|d delta / d pixel| near or above 1 at the corners).
  constexpr double kTolerancePx = 1e-10;
  constexpr double kStepPx = 1e-4;
  distorted = ideal;
  for (int32_t i = 0; i < kMaxCameraInverseIterations; ++i) {
    const Vec2 back = undistortPixel(d, distorted);
    const Vec2 error = ideal - back;
    if (error.squaredNorm() < kTolerancePx * kTolerancePx) {
      return Status::kOk;
    }
    Mat2 j;
    j.col(0) = (undistortPixel(d, distorted + Vec2(kStepPx, 0.0)) - back) / kStepPx;
    j.col(1) = (undistortPixel(d, distorted + Vec2(0.0, kStepPx)) - back) / kStepPx;
    const double det = j.determinant();
    if (!(std::fabs(det) > 1e-12)) {
      return Status::kDegenerate;
    }
    distorted += j.inverse() * error;
  }
  return Status::kNoConvergence;
}

}  // namespace areomap
