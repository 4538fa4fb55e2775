// Cross-site tie points between two neighbouring sites of a traverse: images of site B
// tied to images of site A that see the same ground from 10-30 m away (large scale and perspective
// change), found through each site's DEM and the a-priori relative pose.
//
//  1. The relative pose of the sites is registered on their DEMs (DemRegistration.hpp), or on their
//     orthoimages where the DEMs are refused (OrthoRegistration.hpp). The registration is a hypothesis the
//     images must confirm: where the ties under it are too few, the orthoimages' pose and the poses the
//     DEMs cannot tell from their best (PoseHypotheses.hpp) are tried too, and the one the most checked
//     ties confirm is kept. A pair whose DEMs do not overlap, or that no hypothesis ties, gets that status
//     and no ties.
//  2. Förstner points of every image of B are cast onto B's DEM, moved into A's frame by the registered
//     pose and kept where A's DEM agrees. Each is predicted into every image of A (and every other image of
//     B, e.g. its stereo partner) that sees it unoccluded through that site's DEM, within range.
//  3. The patch is matched by NCC on the DEM-warped grid (WarpedPatchMatcher.hpp: the ground plane under
//     the point maps one view into the other) with an NCC threshold, a second-peak ratio, a least-squares
//     sub-pixel position and a back-match (J to I) that must land within lr_tolerance_px of the point.
//  4. Geometric check: a bundle of the site pose (x, y, z, heading and tilt of B in A) and every tie's
//     point, from all observations, with a weak prior on the registered pose (the tilt's: the registration's
//     tilt prior, RegistrationParams::tilt_sigma_rad); observations beyond max(floor_px,
//     k robust sigmas) are dropped round by round (and a tie that loses its source, or its last image of
//     either site, goes).
// Every observation is in the delivered image's pixels of the site's own products (x = sample, y = line).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ground/traverse/CrossSiteAdjustment.hpp"
#include "ground/traverse/DemRegistration.hpp"
#include "ground/traverse/SiteProducts.hpp"
#include "ground/traverse/WarpedPatchMatcher.hpp"

namespace areomap::traverse {

struct CrossTieParams {
  RegistrationParams registration;
  PatchParams patch;
  int cell_px = 0;            // Förstner spreading grid (0: the image width / 16, at least 16)
  int per_cell = 2;           // points per cell
  double max_range_m = 30.0;  // from every camera that observes the point
  // Between the views' pixel footprints (the map's mean scale): 0 for the pyramid's reach, the scale whose
  // nearest level is its coarsest (2^(kPyramidLevels - 1) * sqrt 2).
  double max_scale_ratio = 0.0;
  double min_incidence_deg = 4.0;     // of each view's ray on the local ground plane
  double occlusion_tolerance = 0.03;  // a ray may meet the DEM this fraction of its length early
  double max_height_gap_m = 0.3;      // |A's DEM - the point moved into A| (plus 1 % of its range)
  double plane_radius_m = 0.12;       // ground plane under a point: DEM cells within this radius
  double lr_tolerance_px = 1.0;       // back-match distance (pixels of the coarser view)
  double residual_floor_px = 1.0;     // the geometric check never rejects below this
  double residual_sigmas = 4.0;       // ... nor below this many robust sigmas
  int max_check_rounds = 8;
  double prior_sigma_m = 0.5;  // weak prior of the geometric check on the registered pose
  double prior_sigma_deg = 0.5;
  int min_ties = 8;               // fewer: kTooFewTies (the ties found are returned, not used)
  double height_floor_m = 0.05;   // the triangulated point within this of both DEMs ...
  double height_sigmas = 3.0;     // ... or this many dem_sigma
  double first_radius_px = 16.0;  // the first pass's search radius (patch.radius_px without a second pass)
  int first_pass_stride = 4;      // and every this many interest points
  bool second_pass = true;        // match again under the first pass's pose ...
  double second_radius_px = 4.0;  // ... with this search radius
  bool surface_warp = true;       // patches warped through the DEM sample by sample (else its local plane)
  // The search radius of each prediction from its uncertainty (else first_radius_px, second_radius_px):
  // search_sigmas times the pose's covariance (the registration's, then the first pass's) and B's
  // dem_sigma along the source ray, propagated into the image, plus min_radius_px (the least-squares
  // step's own pull-in, also the least radius).
  bool derived_radius = true;
  double search_sigmas = 3.0;
  double min_radius_px = 2.0;
};

struct CrossTieObservation {
  int64_t point = 0;
  std::string site;
  std::string image;  // stem
  Eigen::Vector2d pixel_px = Eigen::Vector2d::Zero();
  bool source = false;  // the interest point the tie was found from
  double ncc = 1.0;     // its NCC with the source patch (1 for the source)
};

struct CrossTie {
  int64_t point = 0;
  Eigen::Vector3d b_m = Eigen::Vector3d::Zero();  // the point in site B's frame (the geometric check's)
  std::vector<CrossTieObservation> observations;
};

enum class CrossTieStatus { kOk, kNoOverlap, kRegistrationFailed, kTooFewTies };
const char* crossTieStatusName(CrossTieStatus status);

struct CrossTieCounts {
  int interest_points = 0;  // in B's images
  int on_both_dems = 0;     // cast onto B's DEM and found on A's
  int predicted = 0;        // (point, image) predictions searched
  // Predictions not searched, by the first gate that refused them (in this order).
  int outside_image = 0;  // projects outside the image (or behind the camera)
  int beyond_range = 0;   // farther than max_range_m from the camera
  int grazing = 0;        // the ray meets the ground plane under min_incidence_deg
  int occluded = 0;       // the ray meets the site's DEM first
  int scale_gate = 0;     // the views' footprints differ by more than max_scale_ratio
  int coarse_source = 0;  // a source pixel spans too much of the target for the check's residual floor
  int too_uncertain = 0;  // the derived search radius is beyond the widest search (counted in predicted)
  // Searched predictions refused by the patch matcher, by cause.
  int patch_outside = 0;  // the patch or its search window leaves the image, or is flat
  int low_ncc = 0;
  int ambiguous = 0;  // second peak
  int edge_peak = 0;
  int lsm_diverged = 0;
  int back_failed = 0;   // the back-match failed or landed too far
  int matched = 0;       // passing NCC, second peak and the sub-pixel refinement
  int back_matched = 0;  // and the back-match
  int ties_before_check = 0;
  int rejected_observations = 0;  // by the geometric check
  int rejected_ties = 0;
  int off_dem_ties = 0;                                     // triangulated off either DEM
  CrossTieCounts& operator+=(const CrossTieCounts& other);  // every count summed
};

struct CrossTieResult {
  CrossTieStatus status = CrossTieStatus::kNoOverlap;
  std::string message;  // one sentence when not kOk
  std::string site_a, site_b;
  DemRegistration registration;
  RelativePose a_from_b;  // the geometric check's pose (the registration's when it did not run)
  PoseVector a_from_b_sigma = PoseVector::Zero();  // x, y, z (m), heading, tilt x, tilt y (rad)
  PoseMatrix a_from_b_covariance = PoseMatrix::Zero();
  double rms_px = 0.0;      // RMS residual of the kept observations
  CrossTieCounts counts;    // of the last pass
  int first_pass_ties = 0;  // kept by the first pass's check
  CrossTieCounts first_pass_counts;
  CrossTieCounts counts_in_a;  // the per-prediction counts of the last pass for A's images alone
  std::vector<CrossTie> ties;
  int observationCount() const;
};

// Ties between sites A and B; `apriori` is A from B under the a-priori site poses. Point ids count up from
// `first_point`.
CrossTieResult findCrossSiteTies(const SiteProducts& a, const SiteProducts& b, const RelativePose& apriori,
                                 const CrossTieParams& params = {}, int64_t first_point = 0);

// The steps after the registration: both passes under `registration` and, where the images do not confirm
// it (fewer than min_ties under it, or it was refused), the other hypotheses — the orthoimages'
// registration, every pose the DEMs cannot tell from their best (PoseHypotheses.hpp) —, each tried by the
// first pass; the one with the most checked ties, when more than the registration's, goes through the
// second pass and is the result when it ties more (its registration's method "ortho" or "dem_hypothesis",
// its message saying why and how many were tried).
CrossTieResult tiesUnderRegistration(const SiteProducts& a, const SiteProducts& b,
                                     DemRegistration registration, const CrossTieParams& params = {},
                                     int64_t first_point = 0);

// The ties as the multi-site adjustment and cross_ties.csv take them: one observation each, ties in order.
std::vector<CrossSiteTie> crossSiteObservations(const std::vector<CrossTie>& ties);

}  // namespace areomap::traverse
