// The sites' poses from cross-site tie points and the odometry (on the ground): every
// site a rigid body carrying its cameras as its own pass adjusted them (its SitePass, site frame),
// its pose and the cross-site points unknown, the odometry legs weighted observations, site 1 the datum
// (firmware_core/adjust/SitePoseAdjuster.hpp, the ground's capacity: the whole traverse at once). A site
// that no cross-site tie links keeps its odometry pose, and its sigma and source say so.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "firmware_core/base/EigenTypes.hpp"
#include "ground/dataset/Traverse.hpp"
#include "ground/traverse/SiteDatum.hpp"
#include "ground/traverse/SitePoses.hpp"

namespace areomap::traverse {

// The tilt sigma of an odometry leg between two levelled site frames (rad): a site frame is levelled by the
// rover's accelerometers, far better than wheel odometry measures heading (0.06 deg; the levelled frames
// of traverse.json have no tilt unknown of their own). Where traverse.json gives the rovers' attitudes (an
// IMU on sloped ground), each site's frame is levelled by its attitude, and the leg's tilt sigma is the root
// sum of both sites' attitude sigmas when that is the larger. The leg's observation of the two camera sets
// adds both sites' datum sigmas (SiteDatum.hpp).
inline constexpr double kLevelSigmaRad = 1e-3;

// A cross-site tie observation: a point id shared by observations of images of different sites, the
// measured (distorted) pixel.
struct CrossSiteTie {
  int64_t point = 0;
  std::string site;   // site id
  std::string image;  // image stem in that site
  Vec2 pixel_px = Vec2::Zero();
};

// Reads `cross_ties.csv` (point,site,image,sample_px,line_px); throws cli::InputError naming the file.
std::vector<CrossSiteTie> readCrossSiteTies(const std::string& path);
void writeCrossSiteTies(const std::string& path, const std::vector<CrossSiteTie>& ties);

// Cross-site ties from a synthetic traverse's truth (as areomap-adjust --truth-ties does within a site):
// every check point of site k (sites/<id>/truth/points.csv, observations.csv) carried by the true poses
// into site k-1's frame and projected by its true models where it falls inside an image, with Gaussian
// noise of `noise_px` per coordinate (seeded). Geometric only (occlusion is not checked): for testing the
// adjustment apart from the matching. Empty when the traverse has no truth.
std::vector<CrossSiteTie> truthCrossSiteTies(const Traverse& traverse, double noise_px, uint64_t seed);

// The ties the adjuster takes: at most kMaxObsPerCrossSitePoint observations a point (the source, then the
// other sites' and the source site's in turn) and, when the whole traverse's ties exceed the adjuster's
// points or observations, an equal share of them per pair of sites, taken round-robin over the source
// images' grid cells (kSelectionCellPx) so that a thinned pair keeps its spread. (The matcher gives a
// navcam pair 1000-3000 ties of 8-12 observations; a 6-DOF pose needs far fewer.)
struct TieSelection {
  std::vector<CrossSiteTie> ties;
  int32_t points_left_out = 0;
  int32_t observations_left_out = 0;  // of the points kept beyond a point's cap, and of the points left out
};
inline constexpr double kSelectionCellPx = 64.0;
TieSelection selectCrossSiteTies(const std::vector<CrossSiteTie>& ties, int32_t max_points,
                                 int32_t max_observations);

struct CrossSiteAdjustment {
  SitePoseSolution poses;
  std::vector<SiteDatum> datum;       // per site (known = false: not mapped, or fewer than 2 pairs)
  int32_t ties_used = 0;              // observations in the adjustment
  int32_t ties_rejected = 0;          // by its robust rejection
  int32_t ties_dropped = 0;           // naming an unknown site or image, or not mappable to ideal pixels
  int32_t points_left_out = 0;        // by selectCrossSiteTies (capacity)
  int32_t observations_left_out = 0;  // by selectCrossSiteTies (a point's cap, capacity)
  double method1_px = -1.0;           // mean |residual| of the cross-site observations (pixel distance)
  double sigma0 = 0.0;
  bool converged = false;
};

// `cameras[k]`: site k's cameras as its pass adjusted them (site frame; empty when the site was not
// mapped). sigma_px: the a-priori sigma of a cross-site observation.
CrossSiteAdjustment adjustSitePoses(const Traverse& traverse, const std::vector<SiteCameras>& cameras,
                                    const std::vector<CrossSiteTie>& ties, double sigma_px);

}  // namespace areomap::traverse
