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

// Unwhitened constraint misfits of a pair, for reports (kRigMisfitBound_m bounds them: 0.1 mm).
struct ConstraintMisfit {
  double gimbal_m = 0.0;    // largest |C - XG - M^T c| of the pair's images
  double base_m = 0.0;      // |C_R - C_L - M_L^T e|
  double distance_m = 0.0;  // largest FIDO distance misfit
};

// The two rig constraints of the paper (§3.2), unwhitened, each with its Jacobian over the local updates:
// Eq. 3 (gimbal, per image): g = C - XG - M^T c, over [dC, delta] of the image;
// Eq. 4 (stereo base, per pair): g = C_R - C_L - M_L^T e, over [left dC, delta, right dC, delta].
void gimbalRows(const Vec3& c, const Mat3& m, const Vec3& xg, const Vec3& offset, Vec3& g, Mat3x6& j);
// Eq. 3 with the tilt arm (Network.hpp TiltArm) of image side `side` (0 left, 1 right) of sol `sol`:
// g = C - XA - M^T o - arm u(M), u = w / |w|, w = a x M^T k; over [dC, delta]: dg/dC = I, dg/ddelta =
// -M^T [o]x - arm (I - u u^T) / |w| [a]x M^T [k]x (M'^T k = M^T k + M^T [k]x delta).
void tiltArmRows(const TiltArm& arm, int32_t side, int32_t sol, const Vec3& c, const Mat3& m, Vec3& g,
                 Mat3x6& j);
void baseRows(const Vec3& c_left, const Mat3& m_left, const Vec3& c_right, const Vec3& base, Vec3& g,
              Mat3x12& j);

// What a constraint row is, and whether it is a measurement: rows of a rig value whose sigma the dataset
// gave are; the datum prior and the rows of a held constraint (a sigma chosen only to make it hold,
// Network.hpp) are not, and the EO covariance takes them out of its sandwich (EoCovariance.hpp).
enum class ConstraintKind : uint8_t { kGimbal, kBase, kSpinCentre, kLrDistance, kDatumPrior };
bool isMeasurement(const RigConstraints& rig, ConstraintKind kind);

// Fills rows (whitened) and their Jacobian for pair `pair` evaluated at the given cameras (right ignored
// for a single image), and each row's kind when `kinds` is given. Returns the number of rows used; unused
// rows are zero.
int32_t pairConstraintRows(const Network& net, int32_t pair, const Vec3& c_left, const Mat3& m_left,
                           const Vec3& c_right, const Mat3& m_right, ConstraintRows& rows,
                           ConstraintJacobian& jacobian, ConstraintMisfit* misfit = nullptr,
                           ConstraintKind* kinds = nullptr);

// The same at the network's current cameras.
int32_t currentPairConstraintRows(const Network& net, int32_t pair, ConstraintRows& rows,
                                  ConstraintJacobian& jacobian, ConstraintMisfit* misfit = nullptr,
                                  ConstraintKind* kinds = nullptr);

// The Jacobian rows (whitened) of pair `pair`'s constraint rows that are no measurement (isMeasurement), at
// the network's current cameras, packed at the top of `jacobian`; returns their number.
int32_t nonMeasurementRows(const Network& net, int32_t pair, ConstraintJacobian& jacobian);

// The largest misfits over all pairs at the network's current cameras (constraints in use only): the
// issue's measure, max over images of |Eq. 3| and over pairs of |Eq. 4|.
ConstraintMisfit networkMisfit(const Network& net);

// How far the rig values disagree among themselves. With free rotations, Eq. 3 for both cameras and Eq. 4
// can all hold only if |c_R| = |c_L + e| (c_R is carried onto c_L + e by the relative rotation); otherwise
// their residuals close a loop g_L - g_R + g_B = d with |d| >= ||c_R| - |c_L + e||, which is returned (0 when
// either constraint is off). No sigma and no image can bring the misfits below the floor it implies.
double rigInconsistency(const RigConstraints& rig);

// That floor at the current sigmas: the least weighted split of the loop, |g_L| = |g_R| = sg^2 d / S and
// |g_B| = sb^2 d / S with S = 2 sg^2 + sb^2 (d / 3 each for equal sigmas).
ConstraintMisfit misfitFloor(const RigConstraints& rig);

// The held-sigma rule of Network.hpp: each held sigma whose misfit exceeds its floor (misfitFloor) by more
// than half of kRigMisfitBound_m is scaled by (kRigMisfitBound_m / 4) / (misfit - floor), floored at
// kMinHeldRigSigma_m; a misfit that is the rig's own floor is left alone (tightening cannot lower it and
// only stiffens the problem). True when a sigma changed, i.e. the network is to be solved again.
bool tightenHeldSigmas(RigConstraints& rig, const ConstraintMisfit& misfit);

// Every held constraint in use holds to kRigMisfitBound_m (given sigmas are not checked).
bool heldConstraintsMet(const RigConstraints& rig, const ConstraintMisfit& misfit);

// The whitened residual (observed - predicted) / sigma of one observation and its Jacobians with respect
// to the image's [dC, delta] (2x6) and the point (2x3), both for the predicted value divided by sigma.
[[nodiscard]] Status observationRow(const NetObservation& obs, const NetImage& image, const Vec3& centre,
                                    const Mat3& m, const Vec3& point, Vec2& residual, Mat2x6* d_image,
                                    Mat2x3* d_point);

// Applies a local update [dC, delta] to a camera.
void applyCameraUpdate(const Vec6& update, Vec3& centre, Mat3& m);

}  // namespace areomap
