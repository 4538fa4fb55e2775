// Residuals and analytic Jacobians of one stereo pair's rig constraints (§3.2) and of one collinearity
// observation (§3.1), in the one form every adjuster uses (fast per-pair solves here, the dense SVD and
// Ceres adjusters on the ground): WHITENED rows r = g / sigma with J = (dg/dx) / sigma, where the unknowns
// of an image are [dC (3, site frame, m), delta (3, camera frame, rad)] of the local update
// C' = C + dC, M' = exp([delta]x) M. A pair's unknowns are [left 6, right 6].
#pragma once

#include <cstdint>

#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/base/EigenTypes.hpp"

namespace areomap {

// Rows of one pair's constraints: gimbal L 3 + gimbal R 3 + base 3 + spin-centre distance L 1 + R 1 +
// left-right distance 1 + datum prior L 3 + R 3.
constexpr int32_t kMaxPairConstraintRows = 18;
using ConstraintRows = Eigen::Matrix<double, kMaxPairConstraintRows, 1>;
using ConstraintJacobian = Eigen::Matrix<double, kMaxPairConstraintRows, 12>;

// Unwhitened constraint misfits of a pair, for reports (the issue bounds them at 0.1 mm).
struct ConstraintMisfit {
  double gimbal_m = 0.0;    // largest |C - XG - M^T c| of the pair's images
  double base_m = 0.0;      // |C_R - C_L - M_L^T e|
  double distance_m = 0.0;  // largest FIDO distance misfit
};

// Fills rows (whitened) and their Jacobian for pair `pair` evaluated at the given cameras (right ignored
// for a single image). Returns the number of rows used; unused rows are zero.
int32_t pairConstraintRows(const Network& net, int32_t pair, const Vec3& c_left, const Mat3& m_left,
                           const Vec3& c_right, const Mat3& m_right, ConstraintRows& rows,
                           ConstraintJacobian& jacobian, ConstraintMisfit* misfit = nullptr);

// The same at the network's current cameras.
int32_t currentPairConstraintRows(const Network& net, int32_t pair, ConstraintRows& rows,
                                  ConstraintJacobian& jacobian, ConstraintMisfit* misfit = nullptr);

// The whitened residual (observed - predicted) / sigma of one observation and its Jacobians with respect
// to the image's [dC, delta] (2x6) and the point (2x3), both for the predicted value divided by sigma.
[[nodiscard]] Status observationRow(const NetObservation& obs, const NetImage& image, const Vec3& center,
                                    const Mat3& m, const Vec3& point, Vec2& residual, Mat2x6* d_image,
                                    Mat2x3* d_point);

// Applies a local update [dC, delta] to a camera.
void applyCameraUpdate(const Vec6& update, Vec3& center, Mat3& m);

}  // namespace areomap
