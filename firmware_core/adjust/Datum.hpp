// The free datum (DESIGN.md "Datum"): without ground control a common rotation of every camera and point
// about the gimbal centre changes no observation. Every comparison with truth first removes the best-fit
// common rotation R (estimated camera M maps to M R^T, a point P to XG + R (P - XG)), and reports raw and
// aligned errors. R is the chordal L2 mean of M_true_i^T M_est_i projected onto SO(3).
#pragma once

#include <cstdint>

#include "firmware_core/adjust/Network.hpp"

namespace areomap {

// Best-fit common rotation from pairs of rotations (count > 0).
Mat3 commonRotation(const Mat3* estimated, const Mat3* truth, int32_t count);

// Errors of a network against truth (arrays indexed like the network's images and points; a point with a
// non-finite truth is skipped). `aligned` removes the common rotation about `gimbal_m` first.
// eo_px: RMS over images of eoPixelEquivalent at `range_m`; ground_m: RMS 3-D over solvable points.
struct TruthErrors {
  double eo_px = 0.0;
  double ground_m = 0.0;
  int32_t points = 0;
};
TruthErrors truthErrors(const Network& net, const Vec3* true_centres, const Mat3* true_rotations,
                        const Vec3* true_points, const Vec3& gimbal_m, bool aligned, double range_m);

}  // namespace areomap
