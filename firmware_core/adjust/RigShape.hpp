// Whether a network's a-priori cameras turn about one point (the paper's Eq. 3) or need the FIDO-style
// model (§3.2: a virtual spin centre per tier, camera-to-centre and left-right distances), and that model's
// values, from the a-priori camera centres and rotations alone: the one rule of the rover and the ground.
// Fixed-size Eigen, stack arrays bounded by Capacities.hpp, no heap.
//
// The rule. Eq. 3 (a gimbal centre per sol, a camera offset c per side) is fitted to the a-priori cameras by
// linear least squares (the gimbal centres eliminated per sol, minimum norm over the offsets). Pointing-
// derived models of a rig that turns about one point satisfy it exactly: a pointing error turns the head
// about that point. A dataset whose pointing errors moved the rotations alone leaves each centre off by at
// most |c| times the pointing error, i.e. |c| sigma_point with sigma_point the network's a-priori rotation
// sigma (RigConstraints::sigma_datum_rad, an upper figure of the pointing error). So a fit that misses the
// centres by more than kRigMisfitBound_m + |c| sigma_point RMS (|c| the larger fitted offset) is more than
// any one-point rig shows: the mast's axes do not meet (e.g. a tilt axis off the pan axis), holding Eq. 3
// to kRigMisfitBound_m would bend the network, and the FIDO model is used instead. One tier of such a mast
// pans about one axis and fits Eq. 3 exactly: it stays with Eq. 3, which then holds without bending.
#pragma once

#include <cstdint>

#include "firmware_core/adjust/Network.hpp"

namespace areomap {

struct RigShape {
  double fit_rms_m = 0.0;    // RMS over the images of |C - XG_sol - M^T c_side| at the fitted Eq. 3
  double lever_m = 0.0;      // the larger fitted |c|
  double threshold_m = 0.0;  // kRigMisfitBound_m + lever_m * rig.sigma_datum_rad
  bool one_point = true;     // fit_rms_m <= threshold_m (also when the network has no image)
};

// The rule above on net's a-priori cameras (net.image(i).centre_apriori_m, m_apriori, sol, side).
RigShape checkRigShape(const Network& net);

// What fitTiltArm found, for reports.
struct TiltArmFit {
  bool fitted = false;  // false: the tilts do not span a plane, or no image
  double arm_m = 0.0;   // the tilt axis's distance from the pan axis
  double rms_m = 0.0;   // RMS over the images of the model's miss at the a-priori centres
};

// Eq. 3 with the tilt arm (Network.hpp TiltArm) fitted to the a-priori cameras into net.rig.tilt_arm: the
// pan axis and each side's tilt axis from the rotations alone (the rotations between images of a tier
// turn about the pan axis; the pan axis seen from a camera turns about the tilt axis; then a . M_i^T k = 0
// solved for both by Gauss-Newton), then XA per sol,
// the offsets and the arm by Eq. 3's linear least squares with the arm's column (XA eliminated per sol,
// minimum norm). Leaves use_tilt_arm alone.
TiltArmFit fitTiltArm(Network& net);

// A tier needs this many images for its sphere fit (a sphere has four unknowns); a tier with fewer gets no
// spin centre (its images keep the stereo base and the left-right distance).
constexpr int32_t kMinSpinCentreImages = 4;

// What fitFidoRig found, for reports.
struct FidoFit {
  int32_t tiers = 0;             // tiers with a spin centre
  double distance_rms_m = 0.0;   // RMS of |C - S_tier| - d_side at the a-priori centres
  int32_t lr_pairs = 0;          // pairs behind lr_distance_m
  TiltArmFit tilt_arm;           // fitTiltArm's
};

// The FIDO values from the a-priori cameras into net.rig: per tier with at least kMinSpinCentreImages images
// the virtual spin centre (sphere fit |C - S|^2 = d^2 over the tier's centres, both sides, linear in S and
// d^2 - |S|^2, relative to the tier's mean centre and minimum norm: a tier that only pans leaves S free
// along the pan axis, and the choice must not depend on where the frame's origin lies), the mean
// camera-to-centre distance per side over those tiers and the mean left-right distance over the pairs;
// and the tilt arm (fitTiltArm). Leaves the use_* switches and the sigmas alone.
FidoFit fitFidoRig(Network& net);

// The switch to the FIDO model. With a fitted tilt arm: Eq. 3 with the arm (three rows per camera that tie
// its centre to its rotation), held (its values are always fitted, never given: sigma kHeldRigSigma_m,
// tightened to kRigMisfitBound_m), the spin-centre and left-right distances off (the arm implies them).
// Without (the tilts do not fix the axes): Eq. 3 off, the spin-centre distances on, the left-right
// distance on when a pair has a right image, their sigma the base's. Either way the stereo base (Eq. 4)
// on when a pair has a right image.
void useFidoModel(Network& net);

}  // namespace areomap
