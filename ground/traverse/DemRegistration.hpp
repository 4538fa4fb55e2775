// Coarse relative pose of two neighbouring sites from their DEMs (cross-site ties, step 1). The
// a-priori site poses (traverse.json) carry the odometry's drift (~5 % of the leg in position, ~2 deg per
// leg in heading); registering site B's DEM onto site A's removes most of it, so that the image search
// windows of the tie matcher stay a few pixels wide.
//
// Method: B's DEM cells (those that fall into A's DEM under the a-priori pose) are moved into A's frame by a
// relative pose and compared with A's elevation there. A grid search over +-search_m in x, y and
// +-search_deg in heading (the z offset is the weighted mean difference at each candidate; where the tilt
// is solved, it is the plane of the differences, drawn to the a-priori tilt by its prior: Moments::
// levelledVariance, no dimension of the grid) minimises the weighted variance of the differences, coarse then
// fine; a Gauss-Newton refinement on the DEM gradients (iteratively reweighted, differences beyond 3 robust
// sigmas trimmed) gives the pose and its covariance. The refinement also solves the two frames' relative tilt
// (each site frame is levelled by its own rover's attitude, an IMU's on sloped ground, so two frames are
// tilted against each other by both attitude errors: 5 cm at 10 m for 0.3 deg, which a levelled pose leaves
// in the differences and in its translation), with the attitudes' sigmas as a weighted prior row
// (tilt_sigma_rad), so that the DEMs' data bound it where they can and the prior where they cannot. The DEMs'
// differences are correlated over some distance (each DEM is smoothed, its errors come in patches), so the
// least-squares covariance, which takes every sample as independent, is inflated by the design effect
// measured on the residuals themselves: the variance of their means over blocks of side L against the
// variance of a mean of independent samples, the largest over L from 4 sample spacings to a quarter of the
// overlap. The match is refused when the overlap is too small, or ambiguous: a second minimum of the coarse
// search, away from the best, nearly as good. A refusal's message says why in the data's figures: the DEMs'
// differences against their dem_sigma layers, and the change the relief they share makes to them between the
// best pose and the second minimum against the differences themselves (on the tiny camera's own products
// 0.5-2.6 cm against 6-7 cm: the DEMs are too noisy for their relief, and the fit drifts to where they are
// least noisy). A refused match is tried again on the sites' orthoimages when both have one
// (OrthoRegistration.hpp).
#pragma once

#include <string>

#include <Eigen/Core>

#include "ground/dataset/Traverse.hpp"
#include "ground/traverse/SiteProducts.hpp"

namespace areomap::traverse {

// The parameters of a relative pose's covariance, in this order: x, y, z (m), heading, tilt about A's x,
// tilt about A's y (rad).
using PoseVector = Eigen::Matrix<double, 6, 1>;
using PoseMatrix = Eigen::Matrix<double, 6, 6>;

// Rigid map of site B's frame into site A's: p_a = R p_b + translation, R = exp([tilt]x) Rz(heading), where
// the tilt is a rotation about A's horizontal axes by the vector (tilt_rad.x(), tilt_rad.y(), 0): the
// levelling of B's frame against A's (zero between two truly levelled frames).
struct RelativePose {
  Eigen::Vector3d translation_m = Eigen::Vector3d::Zero();
  double heading_rad = 0.0;
  Eigen::Vector2d tilt_rad = Eigen::Vector2d::Zero();

  Eigen::Matrix3d rotation() const;
  Eigen::Vector3d toA(const Eigen::Vector3d& b_m) const { return rotation() * b_m + translation_m; }
  Eigen::Vector3d toB(const Eigen::Vector3d& a_m) const {
    return rotation().transpose() * (a_m - translation_m);
  }
  RelativePose inverse() const;
};

// `base` moved by dx, dy (m) and turned by dh (rad) in heading (its tilt kept).
RelativePose shiftedPose(const RelativePose& base, double dx, double dy, double dh);

// `base` turned by the rotation vector `omega_rad` about A's axes (R' = exp([omega]x) R), its translation
// kept: the update of a Gauss-Newton step whose rotation unknowns are small turns about A's x, y, z.
RelativePose turnedPose(const RelativePose& base, const Eigen::Vector3d& omega_rad);

// The relative pose of rotation `r` (any rotation: its tilt the least rotation that carries A's vertical
// onto r's image of it, the heading what is left) and translation `translation_m`.
RelativePose relativePoseOf(const Eigen::Matrix3d& r, const Eigen::Vector3d& translation_m);

// d(R b) / d(omega) for such a turn about A's axes: -[R b]x (columns: about x, y, z).
Eigen::Matrix3d turnJacobian(const Eigen::Vector3d& rotated_b);

// A's frame from B's through two site poses in the traverse frame.
RelativePose relativePose(const SitePose& a, const SitePose& b);

enum class RegistrationStatus { kOk, kNoOverlap, kAmbiguous, kNotConverged };
const char* registrationStatusName(RegistrationStatus status);

struct RegistrationParams {
  double search_m = 2.0;               // +- in x and y about the a-priori translation
  double search_deg = 5.0;             // +- in heading about the a-priori heading
  double max_range_m = 30.0;           // cells used: within this horizontal range of both site origins
  double max_sigma_m = 0.10;           // and with dem_sigma below it (when the site has one)
  int min_overlap_cells = 200;         // fewer common cells: kNoOverlap
  double sample_spacing_m = 0.1;       // B's cells are thinned to this spacing for the search
  double max_cost_ratio = 0.7;         // best / second-best minimum of the coarse search above it: kAmbiguous
  double second_min_distance_m = 0.6;  // a second minimum lies this far from the best (or second_min_deg)
  double second_min_deg = 2.0;
  // What the window was asked to cover (searchWindowOf: 3 sigmas of the odometry between the sites;
  // 0: not known). A window narrower than this cuts the a-priori pose's 3-sigma range (windowCut).
  double three_sigma_m = 0.0;
  double three_sigma_deg = 0.0;
  // The a-priori sigma (rad, per axis) of the two frames' relative tilt about the a-priori pose's
  // (searchWindowOf: both sites' attitude sigmas, at least the levelling's kLevelSigmaRad). The refinement
  // solves the tilt with it as a prior row; 0: the tilt is held (a levelled registration of x, y, z,
  // heading).
  double tilt_sigma_rad = 0.0;
};

// The widest window searchWindowOf gives: the coarse grid keeps about 10 steps each side, so a wider window
// coarsens the DEMs it compares beyond the relief a registration needs (the step is a tenth of the window).
inline constexpr double kMaxSearchM = 15.0;
inline constexpr double kMaxSearchDeg = 30.0;

struct DemRegistration {
  RegistrationStatus status = RegistrationStatus::kNoOverlap;
  std::string message;                         // one sentence for the report when not kOk
  RelativePose apriori;                        // A from B as given
  RelativePose a_from_b;                       // registered (the a-priori pose when not kOk)
  PoseVector sigma = PoseVector::Zero();       // x, y, z (m), heading, tilt x, tilt y (rad)
  PoseMatrix covariance = PoseMatrix::Zero();  // of the same (sigma its diagonal's root)
  double correlation_factor = 1.0;  // the covariance's inflation for spatially correlated DEM differences
  int overlap_cells = 0;            // common cells at the solution (before trimming)
  int used_cells = 0;               // after trimming
  double rms_m = 0.0;               // weighted RMS elevation difference at the solution
  double cost_ratio = 0.0;          // best / second-best minimum of the coarse search
  // What a refusal's message states (docs/traverse.md "Limits"): the differences at the solution
  // (unweighted, untrimmed) and what the DEMs' dem_sigma layers give for them; the coarse search's RMS
  // difference at its best pose, and the relief's signal: sqrt(second minimum - best) of its variances, the
  // second minimum this far away; how far the fit moved from the search's best pose.
  double difference_rms_m = 0.0;
  double dem_sigma_rms_m = 0.0;
  double coarse_rms_m = 0.0;
  double relief_signal_m = 0.0;  // 0: no second minimum
  double second_offset_m = 0.0;
  double second_offset_deg = 0.0;
  double drift_m = 0.0;
  double drift_deg = 0.0;
  // "dem", or "ortho" where the DEMs were refused and the orthoimages registered (OrthoRegistration.hpp;
  // `message` then says why the DEMs were refused); the orthos' NCC at their solution (0: not tried).
  std::string method = "dem";
  double ortho_ncc = 0.0;
};

// The search window of sites i < j of a traverse: 3 sigmas of the odometry between them (the legs'
// covariances chained from site i's frame: a heading error at a site between swings the legs after it), at
// least base.search_m and base.search_deg, at most kMaxSearchM and kMaxSearchDeg; three_sigma_m and
// three_sigma_deg say what 3 sigmas are; tilt_sigma_rad the root sum of both sites' attitude sigmas
// (traverse.json; levelling at rest, independent per site), at least kLevelSigmaRad. The other parameters
// as in `base`.
RegistrationParams searchWindowOf(const Traverse& traverse, int i, int j,
                                  const RegistrationParams& base = {});

// The coarse search's steps over the window of `params`: about ten each side, at least 0.2 m and 1 degree
// (the DEMs and orthos are averaged to the step).
double coarseStepM(const RegistrationParams& params);
double coarseStepRad(const RegistrationParams& params);

// One sentence when the window cuts the a-priori pose's 3-sigma range ("" when it does not).
std::string windowCut(const RegistrationParams& params);

DemRegistration registerDems(const SiteProducts& a, const SiteProducts& b, const RelativePose& apriori,
                             const RegistrationParams& params = {});

// The orthoimages' registration (OrthoRegistration.hpp) in place of `refused`, a DEM registration that
// `why` (its message) says cannot be used: kOk with method "ortho" where the orthos register, else
// kNotConverged at the a-priori pose.
DemRegistration registerOrthosInstead(const SiteProducts& a, const SiteProducts& b, DemRegistration refused,
                                      const std::string& why, const RegistrationParams& params);

}  // namespace areomap::traverse
