// The rig-shape rule (firmware_core/adjust/RigShape.hpp) on a-priori cameras made here: a mast head whose
// tilt axis meets the pan axis (a one-point rig, Eq. 3 exact) or lies `tilt_axis_m` ahead of it (a
// FIDO-like mast), tiers of pairs all round, a random 3-15 px pan/tilt pointing error per pair, over seeds.
// One point: not switched, also when the pointing errors moved the rotations alone; an offset tilt axis
// over two tiers: switched, and the sphere fit of a one-point rig finds its gimbal centre. The tilt arm
// (Eq. 3 with the arm) fitted to the a-priori cameras holds at the true ones, and, unlike the spin-centre
// distance, does not let a centre slide along its circle; its Jacobian against numeric differences.
#include <cmath>
#include <cstdio>
#include <random>

#include "firmware_core/adjust/Constraints.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/adjust/RigShape.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/adjust/SyntheticPanorama.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

Network g_shape_net;
// The true camera (pan and tilt without the pointing error) of each network image of the last makeMast.
Vec3 g_true_centre[kMaxImages];
Mat3 g_true_m[kMaxImages];

struct MastSpec {
  double tilt_axis_m = 0.0;          // tilt axis ahead of the pan axis
  double tilts_deg[2] = {20.0, 42.0};
  int32_t tiers = 2;
  bool rotation_only_error = false;  // the pointing error moves the rotations, not the centres
  int32_t pans = 12;                 // pairs per tier
  double pan_step_deg = 30.0;
};

constexpr double kFocalPx = 1236.0;
const Vec3 kGimbal(12.0, -7.0, 1.5);

// Camera position relative to the tilt axis in the camera frame of the left and right camera (a 0.2 m base,
// the cameras 8 cm in front of and 5 cm above the axis).
Vec3 cameraOffset(bool right) {
  return Vec3(right ? 0.1 : -0.1, 0.05, -0.08);
}

// The a-priori cameras of the mast into g_shape_net.
void makeMast(const MastSpec& spec, uint32_t seed) {
  g_shape_net.clear();
  g_shape_net.rig = RigConstraints{};
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const InteriorOrientation io = test::centredPinhole(kFocalPx, 1024, 1024);
  for (int32_t t = 0; t < spec.tiers; ++t) {
    for (int32_t k = 0; k < spec.pans; ++k) {
      const double error = (3.0 + 12.0 * u(rng)) / kFocalPx;
      const double direction = 2.0 * M_PI * u(rng);
      const double pan = spec.pan_step_deg * k * M_PI / 180.0;
      const double tilt = spec.tilts_deg[t] * M_PI / 180.0;
      const double pan_err = pan + error * std::cos(direction);
      const double tilt_err = tilt + error * std::sin(direction);
      const Mat3 m = test::lookRotation(pan_err, tilt_err);
      const Mat3 m_centre = spec.rotation_only_error ? test::lookRotation(pan, tilt) : m;
      const double pan_centre = spec.rotation_only_error ? pan : pan_err;
      const Vec3 axis = spec.tilt_axis_m * Vec3(std::cos(pan_centre), std::sin(pan_centre), 0.0);
      const Vec3 cl = kGimbal + axis + m_centre.transpose() * cameraOffset(false);
      const Vec3 cr = kGimbal + axis + m_centre.transpose() * cameraOffset(true);
      int32_t pair = -1;
      CHECK(ok(g_shape_net.addPair(0, t, io, cl, m, &io, cr, m, pair)));
      const Mat3 m_true = test::lookRotation(pan, tilt);
      const Vec3 axis_true = spec.tilt_axis_m * Vec3(std::cos(pan), std::sin(pan), 0.0);
      for (int32_t side = 0; side < 2; ++side) {
        const int32_t image = side == 0 ? g_shape_net.pair(pair).left : g_shape_net.pair(pair).right;
        g_true_m[image] = m_true;
        g_true_centre[image] = kGimbal + axis_true + m_true.transpose() * cameraOffset(side == 1);
      }
    }
  }
}

}  // namespace

TEST_GROUP(RigShape){};

TEST(RigShape, AOnePointRigIsNotSwitchedAndItsSphereFitFindsTheGimbalCentre) {
  for (const uint32_t seed : {11u, 12u, 13u}) {
    makeMast(MastSpec{}, seed);
    const RigShape shape = checkRigShape(g_shape_net);
    std::printf("\n  seed %u one point: fit %.3g mm RMS, limit %.3f mm, lever %.3f m", seed,
                shape.fit_rms_m * 1000.0, shape.threshold_m * 1000.0, shape.lever_m);
    CHECK(shape.one_point);
    CHECK(shape.fit_rms_m < 1e-9);
    DOUBLES_EQUAL(cameraOffset(false).norm(), shape.lever_m, 1e-9);  // c of Eq. 3 is the camera's offset
    const FidoFit fit = fitFidoRig(g_shape_net);
    CHECK_EQUAL(2, fit.tiers);
    CHECK_EQUAL(24, fit.lr_pairs);
    for (int32_t t = 0; t < 2; ++t) CHECK((g_shape_net.rig.spin_centre_m[t] - kGimbal).norm() < 1e-6);
    DOUBLES_EQUAL(cameraOffset(false).norm(), g_shape_net.rig.left_distance_m, 1e-6);
    DOUBLES_EQUAL(0.2, g_shape_net.rig.lr_distance_m, 1e-9);
  }
}

TEST(RigShape, PointingErrorsOfTheRotationsAloneStayWithinTheOnePointLimit) {
  MastSpec spec;
  spec.rotation_only_error = true;
  for (const uint32_t seed : {21u, 22u, 23u}) {
    makeMast(spec, seed);
    const RigShape shape = checkRigShape(g_shape_net);
    std::printf("\n  seed %u rotation-only errors: fit %.3f mm RMS, limit %.3f mm", seed,
                shape.fit_rms_m * 1000.0, shape.threshold_m * 1000.0);
    CHECK(shape.fit_rms_m > 0.0);
    CHECK(shape.one_point);
  }
}

TEST(RigShape, ATiltAxisAheadOfThePanAxisIsSwitchedOverTwoTiersNotOverOne) {
  for (const uint32_t seed : {31u, 32u, 33u}) {
    MastSpec spec;
    spec.tilt_axis_m = 0.10;
    makeMast(spec, seed);
    const HeapAllocationScope heap;
    const RigShape two = checkRigShape(g_shape_net);
    const FidoFit fit = fitFidoRig(g_shape_net);
    useFidoModel(g_shape_net);
    CHECK_EQUAL(0u, heap.allocations());  // the rover's rule: no heap
    std::printf("\n  seed %u tilt axis 0.1 m ahead, 2 tiers: fit %.3f mm RMS, limit %.3f mm; distances %.4f m "
                "RMS %.3f mm",
                seed, two.fit_rms_m * 1000.0, two.threshold_m * 1000.0, g_shape_net.rig.left_distance_m,
                fit.distance_rms_m * 1000.0);
    CHECK(!two.one_point);
    CHECK(g_shape_net.rig.use_gimbal && g_shape_net.rig.use_tilt_arm);
    CHECK(!g_shape_net.rig.use_spin_centre && !g_shape_net.rig.use_lr_distance);
    CHECK(g_shape_net.rig.hold_gimbal);
    CHECK(g_shape_net.rig.use_base);
    spec.tiers = 1;
    makeMast(spec, seed);
    const RigShape one = checkRigShape(g_shape_net);
    std::printf("; 1 tier: fit %.3f mm RMS, limit %.3f mm", one.fit_rms_m * 1000.0, one.threshold_m * 1000.0);
    CHECK(one.one_point);
  }
}

TEST(RigShape, TheTiltArmFittedToTheAprioriCamerasHoldsAtTheTrueOnesAndKeepsEachCentreOnItsRotation) {
  constexpr double kArmM = 0.10;
  MastSpec partial{kArmM};  // three pairs per tier over 90 degrees, like the reduced fido scene
  partial.pans = 3;
  partial.pan_step_deg = 45.0;
  for (const uint32_t seed : {41u, 42u, 43u, 44u, 45u, 46u}) {
    makeMast(seed < 44u ? MastSpec{kArmM} : partial, seed);
    const HeapAllocationScope heap;
    const TiltArmFit fit = fitTiltArm(g_shape_net);
    CHECK_EQUAL(0u, heap.allocations());
    const TiltArm& arm = g_shape_net.rig.tilt_arm;
    std::printf("\n  seed %u: arm %.6f m, %.3g mm RMS at the a-priori centres", seed, fit.arm_m,
                fit.rms_m * 1000.0);
    CHECK(fit.fitted);
    DOUBLES_EQUAL(kArmM, std::fabs(fit.arm_m), 1e-9);
    CHECK(fit.rms_m < 1e-9);
    CHECK(arm.pan_axis.cross(Vec3::UnitZ()).norm() < 1e-9);
    CHECK((arm.centre_m[0] - kGimbal).norm() < 1e-9);
    double worst = 0.0, slid = 1e9;
    constexpr double kSlideRad = 1e-3;  // a centre turned about the pan axis, its rotation kept
    for (int32_t i = 0; i < g_shape_net.imageCount(); ++i) {
      const int32_t side = g_shape_net.image(i).side == Side::kLeft ? 0 : 1;
      Vec3 g;
      Mat3x6 j;
      tiltArmRows(arm, side, 0, g_true_centre[i], g_true_m[i], g, j);
      worst = std::fmax(worst, g.norm());
      const Vec3 r = g_true_centre[i] - kGimbal;
      const Vec3 turned = kGimbal + Eigen::AngleAxisd(kSlideRad, Vec3::UnitZ()) * r;
      tiltArmRows(arm, side, 0, turned, g_true_m[i], g, j);
      slid = std::fmin(slid, g.norm() / (kSlideRad * r.head<2>().norm()));
    }
    CHECK(worst < 1e-9);             // the true cameras satisfy the fitted model
    DOUBLES_EQUAL(1.0, slid, 1e-3);  // a slide along the circle is seen in full (the distance sees none)
  }
}

TEST(RigShape, TheTiltArmRowsJacobianAgreesWithNumericDifferences) {
  makeMast(MastSpec{0.10}, 51u);
  (void)fitTiltArm(g_shape_net);
  const TiltArm& arm = g_shape_net.rig.tilt_arm;
  constexpr double kStep = 1e-7;
  for (const int32_t i : {0, 5, 13, 30}) {
    const NetImage& im = g_shape_net.image(i);
    const int32_t side = im.side == Side::kLeft ? 0 : 1;
    // Away from the fitted model, so that every term of the Jacobian matters.
    const Vec3 c = im.centre_apriori_m + Vec3(0.01, -0.02, 0.015);
    const Mat3 m = rotationFromVector(Vec3(0.02, -0.01, 0.03)) * im.m_apriori;
    Vec3 g0;
    Mat3x6 j;
    tiltArmRows(arm, side, im.sol, c, m, g0, j);
    for (int32_t k = 0; k < 6; ++k) {
      Vec6 step = Vec6::Zero();
      step(k) = kStep;
      Vec3 cp = c, cm = c;
      Mat3 mp = m, mm = m;
      applyCameraUpdate(step, cp, mp);
      applyCameraUpdate(-step, cm, mm);
      Vec3 gp, gm;
      Mat3x6 unused;
      tiltArmRows(arm, side, im.sol, cp, mp, gp, unused);
      tiltArmRows(arm, side, im.sol, cm, mm, gm, unused);
      const Vec3 numeric = (gp - gm) / (2.0 * kStep);
      CHECK((numeric - j.col(k)).norm() < 1e-6);
    }
  }
}
