#include "ground/traverse/RoverPoses.hpp"

#include <cmath>

namespace areomap::traverse {

RoverPoseComparison compareRoverPoses(const SitePoseSolution& ground, const SitePoseSolution& rover,
                                      const std::optional<TraverseTruth>& truth) {
  RoverPoseComparison c;
  std::vector<SitePose> rover_poses, ground_poses;
  std::vector<double> distance;
  std::vector<bool> include;
  double sum2 = 0.0;
  for (const SitePoseEstimate& g : ground.sites) {
    const SitePoseEstimate* r = nullptr;
    for (const SitePoseEstimate& e : rover.sites) {
      if (e.id == g.id) r = &e;
    }
    ground_poses.push_back(g.pose);
    distance.push_back(g.distance_m);
    include.push_back(r != nullptr);
    rover_poses.push_back(r != nullptr ? r->pose : g.pose);
    if (r == nullptr) {
      c.missing.push_back(g.id);
      continue;
    }
    const double d = (r->pose.position_m - g.pose.position_m).norm();
    c.vs_ground_m.push_back(d);
    sum2 += d * d;
    c.sites += 1;
  }
  if (c.sites > 0) c.vs_ground_rms_m = std::sqrt(sum2 / c.sites);
  if (truth && truth->poses.size() == ground_poses.size() && c.sites > 0) {
    const PositionErrors r = positionErrors(rover_poses, distance, *truth, include);
    const PositionErrors g = positionErrors(ground_poses, distance, *truth, include);
    c.error_m = r.rms_m;
    c.error_pct = r.rms_pct;
    c.ground_error_m = g.rms_m;
    c.ground_error_pct = g.rms_pct;
  }
  return c;
}

}  // namespace areomap::traverse
