// The rover's own site poses (AREOMAP_SITE_POSE, found on board: firmware_core/node/RoverTraverse.hpp)
// against the ground's (poses.csv) and the truth: what `areomap-ground --traverse` writes as
// rover_poses.csv beside poses.csv and reports in report.json `rover_poses`.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ground/dataset/Traverse.hpp"
#include "ground/traverse/SitePoses.hpp"

namespace areomap::traverse {

struct RoverPoseComparison {
  int sites = 0;                       // sites the rover published a pose for
  std::vector<std::string> missing;    // traverse sites it did not
  std::vector<double> vs_ground_m;     // per published site |p_rover - p_ground| (traverse order)
  double vs_ground_rms_m = 0.0;
  // Against the truth (-1 without one), over the published sites (positionErrors): the rover's, and the
  // ground's over the same sites.
  double error_m = -1.0, error_pct = -1.0;
  double ground_error_m = -1.0, ground_error_pct = -1.0;
};

// `ground`: the ground's poses, one per traverse site in order; `rover`: the rover's, any subset of the
// sites by id.
RoverPoseComparison compareRoverPoses(const SitePoseSolution& ground, const SitePoseSolution& rover,
                                      const std::optional<TraverseTruth>& truth);

}  // namespace areomap::traverse
