// The image network of one panorama (Di, Xu, Li §3.1-§3.3): images, stereo pairs, tie points with their
// observations, and the rig constraints (Eq. 3, Eq. 4 and the FIDO-style variants). Fixed arrays sized by
// firmware_core/base/Capacities.hpp, no heap: the network is a caller-owned object allocated once (it is
// several MiB: make it static or a member of a static workspace). The rover builds it incrementally as pairs
// arrive; the adjusters (FastAdjuster here, the integrated ones on the ground) read and update it.
//
// Observations are IDEAL pixels of a distortion-free pinhole (the measured pixel mapped once through the
// exact camera inverse), so every adjuster uses collinearity() of firmware_core/camera/Photogrammetric.hpp.
#pragma once

#include <cstdint>

#include <Eigen/Eigenvalues>  // fixed-size 3x3 eigen solver (no heap)

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/Status.hpp"
#include "firmware_core/camera/Photogrammetric.hpp"
#include "firmware_core/camera/RayIntersection.hpp"  // intersectRays, for the points of the network

namespace areomap {

enum class Side : uint8_t { kLeft = 0, kRight = 1 };

struct NetImage {
  int32_t pair = -1;
  Side side = Side::kLeft;
  int32_t sol = 0;   // index into RigConstraints::gimbal_m
  int32_t tier = 0;  // index into RigConstraints::spin_centre_m
  InteriorOrientation io;
  Vec3 centre_m = Vec3::Zero();          // current X0, Y0, Z0 (site frame)
  Mat3 m = Mat3::Identity();             // current rotation, site -> camera
  Vec3 centre_apriori_m = Vec3::Zero();  // a-priori (pointing-derived) values
  Mat3 m_apriori = Mat3::Identity();
  Vec6 sigma = Vec6::Zero();  // a-posteriori sigmas: centre (m), rotation (rad, camera frame)
};

struct NetPair {
  int32_t left = -1;
  int32_t right = -1;  // -1: a single image
  // A-posteriori covariance of the pair's EO [left dC, delta, right dC, delta] (EoCovariance.hpp); a single
  // image has its right half zero.
  Mat12 covariance = Mat12::Zero();
};

struct NetPoint {
  Vec3 xyz_m = Vec3::Zero();
  int32_t obs[kMaxObsPerPoint] = {};
  int32_t obs_count = 0;
  bool solvable = true;  // false when its rays do not fix it (fewer than 2 active rays, parallel rays)
};

struct NetObservation {
  int32_t point = -1;
  int32_t image = -1;
  Vec2 ideal_px = Vec2::Zero();
  double sigma_px = 0.3;  // a-priori standard deviation (Eq. 2 weight = 1 / sigma^2)
  bool rejected = false;  // set by the robust rejection; rejected observations carry no weight
};

// Constraint sigmas a dataset does not give ("held" constraints, the default). The paper weights Eq. 3 and
// Eq. 4 with very small variances (§3.2); here that means the adjusted cameras must satisfy them to
// kRigMisfitBound_m. A whitened constraint row pulls its residual g towards zero against the images' pull:
// with the images' own information w on g (1/m^2) and an image-only discrepancy z / sqrt(w) (z a normal
// deviate), g = z sqrt(w) / (w + 1/sigma^2) <= z sigma / 2 whatever w is (the maximum is at w = 1/sigma^2;
// measured: 0.45-0.8 sigma on the test rigs, from 1 mm down to 0.1 um). So sigma = bound / 10 holds the
// bound for z up to 20, i.e. also for tie points 4x noisier than their sigma_px at a 5-sigma deviate, on
// any camera, base or network. What that does not cover is a rig value that disagrees with the images (g
// then tends to the disagreement when w >> 1/sigma^2): after the adjustment a held sigma whose largest
// misfit exceeds half the bound is divided by at least 2 (by misfit / (bound / 4), the factor that the
// linear bound asks for) and the network solved again, at most kMaxRigTightenings times and never below
// kMinHeldRigSigma_m. Rig values that disagree among themselves leave a floor that no sigma lowers
// (Constraints.hpp rigInconsistency): there the misfit above the floor is what is compared and scaled.
constexpr double kRigMisfitBound_m = 1e-4;
constexpr double kHeldRigSigma_m = kRigMisfitBound_m / 10.0;
// The tightest held sigma (~1e11 per whitened row): below it the stiff rows slow Levenberg-Marquardt
// (35-60 instead of 6-9 steps at 0.1-0.3 um) and stall the alternation (1000 sweeps at 1 um) on a 0.42 m
// wide-angle rig, as measured for tests/firmware_core/adjust HeldRig; at it all three methods agree.
constexpr double kMinHeldRigSigma_m = kRigMisfitBound_m * 0.03;
constexpr int32_t kMaxRigTightenings = 4;  // each at least halves the sigma; the linear bound needs one

// A mast whose tilt axis does not meet its pan axis (a FIDO-like head): each camera centre is
//   C_i = XA_sol + M_i^T o_side + arm u_i,   u_i = unit(pan_axis x M_i^T tilt_axis_side),
// XA the point of the pan axis nearest the tilt axis, arm the tilt axis's distance from the pan axis along
// u (the horizontal direction the head faces, turned by the pan alone), o the camera's offset from the
// tilt axis in its camera frame. It is Eq. 3 with the lever of the pan: three rows per camera that tie the
// centre to the rotation, as Eq. 3 does on a one-point rig (RigShape.hpp fitFidoRig fits it).
struct TiltArm {
  Vec3 centre_m[kMaxSols] = {};  // XA per sol
  bool centre_set[kMaxSols] = {};
  Vec3 offset_m[2] = {};         // o of the left and right camera, camera frame
  Vec3 tilt_axis[2] = {};        // unit tilt axis in the left and right camera frame
  Vec3 pan_axis = Vec3::Zero();  // unit, site frame
  double arm_m = 0.0;
};

// The rig constraints as pseudo-observations with very small variances (§3.2). Each can be switched off.
// Eq. 3 (per image):  C_i - XG_sol - M_i^T c_side = 0   (c = camera centre minus gimbal centre, camera frame)
// Eq. 4 (per pair):   C_R - C_L - M_L^T e = 0           (e = C_R - C_L in the left camera frame)
// FIDO variants (rigs without a calibration report): |C_i - S_tier| = d_side (a virtual spin centre per
// tier), |C_R - C_L| = d_LR; or, where the mast's axes do not meet, Eq. 3 with its tilt arm (TiltArm). A
// weak prior on every rotation towards its a-priori value keeps the datum of the free network (the common
// rotation about the gimbal centre has zero curvature otherwise).
struct RigConstraints {
  bool use_gimbal = true;
  bool use_base = true;
  bool use_spin_centre = false;
  bool use_lr_distance = false;
  bool use_datum_prior = true;

  Vec3 gimbal_m[kMaxSols] = {};
  bool gimbal_set[kMaxSols] = {};
  Vec3 left_offset_m = Vec3::Zero();
  Vec3 right_offset_m = Vec3::Zero();
  Vec3 base_m = Vec3::Zero();
  // The sigmas of Eq. 3 and Eq. 4. hold_*: the dataset gives none, so the sigma starts at kHeldRigSigma_m
  // and the adjusters tighten it until the constraint holds to kRigMisfitBound_m; false: the dataset's
  // sigma, honoured as given (a looser one may leave larger misfits).
  double sigma_gimbal_m = kHeldRigSigma_m;
  double sigma_base_m = kHeldRigSigma_m;
  bool hold_gimbal = true;
  bool hold_base = true;

  Vec3 spin_centre_m[kMaxTiers] = {};
  bool spin_centre_set[kMaxTiers] = {};
  double left_distance_m = 0.0;   // |C_L - S_tier|
  double right_distance_m = 0.0;  // |C_R - S_tier|
  double lr_distance_m = 0.0;     // |C_R - C_L|
  double sigma_distance_m = 0.001;

  // With use_gimbal: Eq. 3 with the tilt arm (TiltArm) instead of the gimbal centres and offsets above;
  // rows, sigma and hold rule are Eq. 3's.
  bool use_tilt_arm = false;
  TiltArm tilt_arm;

  // Datum prior: sigma of each image's rotation about its a-priori value. Weak (0.01 rad = ~10x the
  // pointing error, 1e-5 of the weight of a pair's image data) so that it fixes the zero-curvature
  // direction (to the mean a-priori pointing) and biases nothing measurable.
  double sigma_datum_rad = 0.01;
};

class Network {
 public:
  void clear();

  // Adds a stereo pair (right_io == nullptr: a single left image). Cameras start at their a-priori values.
  [[nodiscard]] Status addPair(int32_t sol, int32_t tier, const InteriorOrientation& left_io,
                               const Vec3& left_centre_m, const Mat3& left_m,
                               const InteriorOrientation* right_io, const Vec3& right_centre_m,
                               const Mat3& right_m, int32_t& pair_index);
  // Adds a tie point (its position is set by triangulate() or by the caller).
  [[nodiscard]] Status addPoint(const Vec3& xyz_m, int32_t& point_index);
  // Adds an observation of `point` in `image` (ideal pixels). kInvalidArgument for bad indices or a second
  // observation of the same point in the same image; kCapacityExceeded when full.
  [[nodiscard]] Status addObservation(int32_t point, int32_t image, const Vec2& ideal_px, double sigma_px);

  // Multi-ray least-squares intersection of the point's active rays with the current EO (the network
  // builder's initial values). kDegenerate for fewer than 2 rays or rays that do not intersect in front.
  [[nodiscard]] Status triangulate(int32_t point);
  [[nodiscard]] Status triangulateAll(int32_t& failed_count);

  // Restores every camera to its a-priori values and clears the rejection flags.
  void resetToApriori();

  int32_t imageCount() const { return image_count_; }
  int32_t pairCount() const { return pair_count_; }
  int32_t pointCount() const { return point_count_; }
  int32_t observationCount() const { return observation_count_; }

  NetImage& image(int32_t i) { return images_[i]; }
  const NetImage& image(int32_t i) const { return images_[i]; }
  NetPair& pair(int32_t i) { return pairs_[i]; }
  const NetPair& pair(int32_t i) const { return pairs_[i]; }
  NetPoint& point(int32_t i) { return points_[i]; }
  const NetPoint& point(int32_t i) const { return points_[i]; }
  NetObservation& observation(int32_t i) { return observations_[i]; }
  const NetObservation& observation(int32_t i) const { return observations_[i]; }

  RigConstraints rig;

 private:
  NetImage images_[kMaxImages];
  NetPair pairs_[kMaxPairs];
  NetPoint points_[kMaxTiePoints];
  NetObservation observations_[kMaxObservations];
  int32_t image_count_ = 0;
  int32_t pair_count_ = 0;
  int32_t point_count_ = 0;
  int32_t observation_count_ = 0;
};

// The unit ray (site frame) of an ideal pixel of a camera.
Vec3 rayOfIdealPixel(const InteriorOrientation& io, const Mat3& m, const Vec2& ideal_px);

// Rotation vector of a rotation matrix (log map), and the angle between two rotations.
Vec3 rotationVector(const Mat3& r);
double rotationAngle(const Mat3& a, const Mat3& b);

}  // namespace areomap
