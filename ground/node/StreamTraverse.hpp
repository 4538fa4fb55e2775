// The traverse steps of `areomap-ground --traverse`, the stream side of the traverse: after the ground
// node has mapped each site's panorama from the LCM stream into OUT/sites/<id>/ (GroundNode.hpp, traverse
// mode), the traverse that the site announcements (AREOMAP_SITE, msgs/site_t.lcm) describe is rebuilt,
// written as OUT/traverse.json (its sites' datasets are OUT/sites/<id>/stream, the images as received) and
// handed with the sites' passes (SitePass values) to finishTraverse (ground/traverse/TraverseRun.hpp), the
// code areomap-traverse runs after its own per-site passes: poses.csv, the sites' models in the traverse
// frame, the merged dem/dem_sigma/ortho and report.json.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "areomap/site_pose_t.hpp"
#include "areomap/site_t.hpp"
#include "ground/dataset/Traverse.hpp"
#include "ground/node/StreamCollector.hpp"
#include "ground/pass/GroundPass.hpp"
#include "ground/traverse/TraverseRun.hpp"

namespace areomap::traverse {

// The traverse of the accepted announcements, in site-index order; each site's path is
// "sites/<id>/stream" under `root`. A site whose odometry is from a site that was not announced (its
// announcement lost or refused) gets a leg from the previous announced site made from the two a-priori
// poses (which are the odometry chained), its distance and sigmas scaled by the legs it spans (a random
// walk: sigma x sqrt(legs), distance x legs) -- one sentence per such site in `warnings`.
Traverse traverseFromAnnouncements(const std::vector<site_t>& sites, const std::string& root,
                                   std::vector<std::string>& warnings);

struct StreamTraverseInputs {
  std::vector<site_t> sites;              // accepted announcements (GroundNodeResult::sites)
  ground::SiteStreamCounts site_counts;   // refusals
  // The passes of the sites whose panorama was made into OUT/sites/<id>, by site id.
  std::map<std::string, std::shared_ptr<const ground::SitePass>> passes;
  std::string truth_traverse;             // a traverse folder with truth/ (the dataset packed), "" none
  std::map<std::string, site_pose_t> rover_site_poses;  // the rover's own, latest per site id (may be empty)
};

// The rover's poses as poses.csv rows, in the traverse's site order (the sites it published): the
// position, the heading, the sigmas of x, y, z and of the rotation about the vertical from its covariance,
// and the source (first_site; cross_site_ties when tied, or held after a tied solve; else odometry).
SitePoseSolution roverPoseSolution(const Traverse& traverse, const std::map<std::string, site_pose_t>& poses);

// Rebuilds the traverse, writes OUT/traverse.json and runs finishTraverse into options.out_dir. Truth (when
// `truth_traverse` is given): its truth/traverse.json poses of the announced sites and truth/dem.tif, and
// with options.truth_cross_ties its sites' truth/ makes the cross-site ties (cli::UsageError without it).
TraverseResult finishStreamTraverse(const StreamTraverseInputs& inputs, const TraverseRunOptions& options);

}  // namespace areomap::traverse
