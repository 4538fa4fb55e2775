// Cross-site ties against a synthetic traverse's truth (tests and areomap-cross-ties): the true point of a
// tie is its source pixel's ray through the source image's true model cast onto the source site's true
// surface (truth/dem.tif); every other observation is compared with that point's projection through the
// true site poses (truth/traverse.json) and the observing image's true model. The DEM registration is
// compared with the true relative pose of the two site frames as their passes map them: on sloped ground
// each frame is levelled by its rover's a-priori attitude, so it is the truly levelled frame turned about
// the rover's base by the attitude error (truth/sim.json "traverse": the attitudes and the base), and two
// frames are tilted against each other by both errors.
#pragma once

#include <string>
#include <vector>

#include "ground/dataset/Traverse.hpp"
#include "ground/traverse/CrossSiteTies.hpp"

namespace areomap::traverse {

struct TruthCheck {
  std::vector<double> errors_px;        // every non-source observation with a true projection
  std::vector<double> cross_errors_px;  // those in site A's images (the cross-site ones)
  double cross_median_px = 0.0, cross_p90_px = 0.0;
  int cross_gross = 0;
  int no_truth = 0;  // observations whose true point could not be found or projected
  double median_px = 0.0, p90_px = 0.0;
  int gross = 0;  // errors above gross_px
  double gross_px = 2.0;
  // Registration (and the geometric check's pose) minus the true relative pose.
  double registration_xy_m = 0.0, registration_z_m = 0.0, registration_heading_deg = 0.0;
  double ties_xy_m = 0.0, ties_z_m = 0.0, ties_heading_deg = 0.0;
  // The relative tilt: the true one's size, and the registration's and the ties' pose's error (its norm).
  double true_tilt_deg = 0.0, registration_tilt_deg = 0.0, ties_tilt_deg = 0.0;
};

// A from B between the two site frames as mapped (above); the levelled relativePose(true_a, true_b) where a
// site's truth/sim.json gives no attitude. Throws when a sim.json cannot be read.
RelativePose mappedTruePose(const TraverseSite& site_a, const TraverseSite& site_b, const SitePose& true_a,
                            const SitePose& true_b);

TruthCheck checkAgainstTruth(const CrossTieResult& result, const TraverseSite& site_a,
                             const TraverseSite& site_b, const SitePose& true_a, const SitePose& true_b,
                             double gross_px = 2.0);

}  // namespace areomap::traverse
