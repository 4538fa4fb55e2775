// The paper's photogrammetric model (Di, Xu, Li §3.1; Wolf & Dewitt): interior orientation, exterior
// orientation (X0, Y0, Z0, omega, phi, kappa) and the collinearity equations (Eq. 1) with analytic
// Jacobians.
//
// Conventions (stated once, used everywhere):
// - M = R_kappa * R_phi * R_omega rotates site-frame vectors into the camera frame (Wolf & Dewitt):
//     m11 = cos(phi)cos(kappa)   m12 = sin(omega)sin(phi)cos(kappa)+cos(omega)sin(kappa)   m13 = ...
//     m31 = sin(phi)             m32 = -sin(omega)cos(phi)          m33 = cos(omega)cos(phi)
//   so omega = atan2(-m32, m33), phi = asin(m31), kappa = atan2(-m21, m11).
// - Camera frame: x along H' (image right), y along -V' (image up), z along -A (the camera looks along -z).
//   The rows of M are these axes in the site frame: M = [H'; -V'; -A].
// - Collinearity in pixels: with d = M (P - C), x = -f d_x / d_z and y = -f d_y / d_z (image-plane
//   coordinates, y up), and sample = x0 + x, line = y0 - y, where (x0, y0) = principal point in pixel
//   coordinates (sample, line) of the delivered image. These are "ideal" pixels: distortion is handled
//   separately (InteriorOrientation::distortion, or exactly through the CAHVOR inverse).
// - Rotation updates in the adjusters are local: M' = exp([delta]x) M (delta in the camera frame), which
//   has no gimbal lock; omega/phi/kappa are for input, output and reports.
#pragma once

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/Status.hpp"

namespace areomap {

// Image-space lens distortion about a centre (cx, cy) in pixels: radial k0..k3 and decentering p1, p2
// (Brown), plus an affinity (scale difference and shear) that absorbs hs != vs and non-orthogonal H, V, and
// a constant shift t1, t2. ideal = distorted + delta(distorted) with, in x = (sample - cx) / norm_px,
// y = (line - cy) / norm_px, r2 = x^2 + y^2:
//   delta_x = x (k0 + k1 r2 + ... + k5 r2^5 + g) + p1 (r2 + 2x^2) + 2 p2 x y + b1 x + b2 y + t1
//   delta_y = y (k0 + k1 r2 + ... + k5 r2^5 + g) + p2 (r2 + 2y^2) + 2 p1 x y + t2
//   with g = (s1 x + s2 y) + r2 (q1 x + q2 y)
// (times norm_px, in pixels).
struct LensDistortion {
  double cx_px = 0.0;
  double cy_px = 0.0;
  double norm_px = 1.0;  // radius normaliser (e.g. f), keeps coefficients well scaled
  double k1 = 0.0, k2 = 0.0, k3 = 0.0;
  double p1 = 0.0, p2 = 0.0;
  double b1 = 0.0, b2 = 0.0;  // affinity: x scale difference, shear
  // Added for the CAHVOR conversion (CameraConversion.hpp): k0 is a uniform radial scale about (cx, cy)
  // (CAHVOR rho0, the k0 of Di & Li 2004) and t1, t2 a constant shift. With the centre on the image point of
  // the O axis and the principal point kept at the CAHV one, a scale about the O point is a scale about the
  // principal point plus a shift: both are needed to fit a real CAHVOR model to 0.05 px.
  double k0 = 0.0;
  double t1 = 0.0, t2 = 0.0;
  // Also added for the conversion: radial terms modulated by a linear form, (x, y) (s1 x + s2 y) and
  // (x, y) r2 (q1 x + q2 y). They are the image-space shape of a radial distortion about an axis O that
  // is tilted against A (CAHVOR: O 7.5 deg off A on a real Spirit Navcam, 0.09 px RMS left without them).
  double s1 = 0.0, s2 = 0.0;
  double q1 = 0.0, q2 = 0.0;
  // Higher radial terms r2^4, r2^5 for wide-angle (CAHVORE fisheye-type) models fitted to a pinhole.
  double k4 = 0.0, k5 = 0.0;
};

struct InteriorOrientation {
  double f_px = 0.0;             // principal distance, pixels
  double x0_px = 0.0;            // principal point: sample of the delivered image
  double y0_px = 0.0;            // principal point: line of the delivered image
  double pixel_size_mm = 0.0;    // 0 = unknown (f in mm = f_px * pixel_size_mm)
  int32_t width = 0;
  int32_t height = 0;
  LensDistortion distortion;
};

struct ExteriorOrientation {
  Vec3 centre_m = Vec3::Zero();  // X0, Y0, Z0 in the site frame
  double omega_rad = 0.0;
  double phi_rad = 0.0;
  double kappa_rad = 0.0;
};

// M(omega, phi, kappa), site -> camera.
Mat3 rotationFromOpk(double omega_rad, double phi_rad, double kappa_rad);
// Angles of a rotation matrix (phi in [-pi/2, pi/2]; at phi = +-pi/2 kappa is set to 0).
void opkFromRotation(const Mat3& m, double& omega_rad, double& phi_rad, double& kappa_rad);

// Derivatives of M with respect to omega, phi and kappa.
void rotationDerivatives(double omega_rad, double phi_rad, double kappa_rad, Mat3& d_omega, Mat3& d_phi,
                         Mat3& d_kappa);

// Collinearity (Eq. 1) in ideal pixels for a camera with centre `centre`, rotation `m` (site -> camera)
// and principal distance/point from `io`. Returns kBehindCamera if the point is not in front (d_z >= 0).
// Optional Jacobians:
//   d_centre  : d(sample, line)/d(X0, Y0, Z0)
//   d_rotation: d(sample, line)/d(delta) for the local update M' = exp([delta]x) M
//   d_point   : d(sample, line)/d(XP, YP, ZP)
[[nodiscard]] Status collinearity(const InteriorOrientation& io, const Vec3& centre, const Mat3& m,
                                  const Vec3& point, Vec2& pixel, Mat2x3* d_centre = nullptr,
                                  Mat2x3* d_rotation = nullptr, Mat2x3* d_point = nullptr);

// The same with the paper's six EO unknowns: d_eo = d(sample, line)/d(X0, Y0, Z0, omega, phi, kappa).
[[nodiscard]] Status collinearityOpk(const InteriorOrientation& io, const ExteriorOrientation& eo,
                                     const Vec3& point, Vec2& pixel, Mat2x6* d_eo = nullptr,
                                     Mat2x3* d_point = nullptr);

// Image-space distortion: the correction of a distorted (measured) pixel to an ideal one, and its
// inverse by bounded fixed-point iteration.
Vec2 undistortPixel(const LensDistortion& d, const Vec2& distorted);
[[nodiscard]] Status distortPixel(const LensDistortion& d, const Vec2& ideal, Vec2& distorted);

}  // namespace areomap
