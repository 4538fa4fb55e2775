#include "firmware_core/match/ParallaxVerifier.hpp"

#include <algorithm>
#include <cmath>

namespace areomap {

double medianInPlace(double* values, int32_t count) {
  if (count <= 0) return 0.0;
  double* mid = values + count / 2;
  std::nth_element(values, mid, values + count);
  double m = *mid;
  if (count % 2 == 0) {
    m = 0.5 * (m + *std::max_element(values, mid));
  }
  return m;
}

Status fitParallaxCurve(const float* rows, const float* parallax_px, int32_t count, const ParallaxParams& params,
                        double row_centre, double row_scale, bool* inlier, double* scratch, ParallaxCurve& curve) {
  curve = ParallaxCurve();
  curve.row_centre = row_centre;
  curve.row_scale = row_scale > 0.0 ? row_scale : 1.0;
  for (int32_t i = 0; i < count; ++i) inlier[i] = true;
  if (count < params.min_points) return Status::kNoTexture;
  // Start from the median parallax (a constant) and a wide band, then refine the quadratic.
  for (int32_t i = 0; i < count; ++i) scratch[i] = parallax_px[i];
  const double median = medianInPlace(scratch, count);
  for (int32_t i = 0; i < count; ++i) scratch[i] = std::fabs(parallax_px[i] - median);
  double tolerance = std::fmax(params.min_tolerance_px, 3.0 * params.sigma_factor * 1.4826 * medianInPlace(scratch, count));
  curve.coefficients = Vec3(median, 0.0, 0.0);
  for (int32_t i = 0; i < count; ++i) inlier[i] = std::fabs(parallax_px[i] - median) <= tolerance;

  for (int32_t iteration = 0; iteration < kMaxParallaxFitIterations; ++iteration) {
    Mat3 normal = Mat3::Zero();
    Vec3 rhs = Vec3::Zero();
    int32_t used = 0;
    for (int32_t i = 0; i < count; ++i) {
      if (!inlier[i]) continue;
      const double t = (rows[i] - curve.row_centre) / curve.row_scale;
      const Vec3 a(1.0, t, t * t);
      normal.noalias() += a * a.transpose();
      rhs.noalias() += a * static_cast<double>(parallax_px[i]);
      ++used;
    }
    if (used < params.min_points) return Status::kNoTexture;
    const Eigen::LDLT<Mat3> ldlt(normal);
    if (ldlt.info() != Eigen::Success || ldlt.rcond() < 1e-12) {
      curve.coefficients = Vec3(curve.coefficients[0], 0.0, 0.0);
    } else {
      curve.coefficients = ldlt.solve(rhs);
    }
    int32_t n = 0;
    for (int32_t i = 0; i < count; ++i) {
      if (inlier[i]) scratch[n++] = std::fabs(parallax_px[i] - curve.evaluate(rows[i]));
    }
    curve.sigma_px = 1.4826 * medianInPlace(scratch, n);
    tolerance = std::fmax(params.min_tolerance_px, params.sigma_factor * curve.sigma_px);
    bool changed = false;
    int32_t kept = 0;
    for (int32_t i = 0; i < count; ++i) {
      const bool in = std::fabs(parallax_px[i] - curve.evaluate(rows[i])) <= tolerance;
      changed = changed || in != inlier[i];
      inlier[i] = in;
      kept += in ? 1 : 0;
    }
    curve.inliers = kept;
    if (!changed) break;
  }
  return curve.inliers >= params.min_points ? Status::kOk : Status::kNoTexture;
}

}  // namespace areomap
