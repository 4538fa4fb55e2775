// The one Eigen configuration of firmware_core: fixed-size types only, named aliases, no dynamic sizes.
// Pass by const&, use .noalias() on products, never `auto` on an expression.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/Cholesky>

namespace areomap {

using Vec2 = Eigen::Matrix<double, 2, 1>;
using Vec3 = Eigen::Matrix<double, 3, 1>;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Vec12 = Eigen::Matrix<double, 12, 1>;
using Mat2 = Eigen::Matrix<double, 2, 2>;
using Mat3 = Eigen::Matrix<double, 3, 3>;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Mat12 = Eigen::Matrix<double, 12, 12>;
using Mat2x3 = Eigen::Matrix<double, 2, 3>;
using Mat2x6 = Eigen::Matrix<double, 2, 6>;
using Mat2x12 = Eigen::Matrix<double, 2, 12>;
using Mat3x6 = Eigen::Matrix<double, 3, 6>;
using Mat3x12 = Eigen::Matrix<double, 3, 12>;
using Mat6x3 = Eigen::Matrix<double, 6, 3>;
using Mat12x3 = Eigen::Matrix<double, 12, 3>;
// Camera conversion (CameraConversion.cpp): the 16-term image-space distortion fit.
using Vec16 = Eigen::Matrix<double, 16, 1>;
using Mat16 = Eigen::Matrix<double, 16, 16>;

// Skew-symmetric matrix: skew(a) * b == a.cross(b).
inline Mat3 skew(const Vec3& a) {
  Mat3 m;
  m << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return m;
}

// Rotation matrix of a rotation vector (Rodrigues), exact to machine precision for small angles.
inline Mat3 rotationFromVector(const Vec3& w) {
  const double theta = w.norm();
  if (theta < 1e-12) {
    return Mat3::Identity() + skew(w);
  }
  return Eigen::AngleAxisd(theta, w / theta).toRotationMatrix();
}

}  // namespace areomap
