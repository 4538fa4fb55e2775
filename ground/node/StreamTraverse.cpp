#include "ground/node/StreamTraverse.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "ground/cli/Cli.hpp"

namespace areomap::traverse {
namespace {

constexpr double kRadPerDeg = M_PI / 180.0;

Eigen::Vector3d vec(const double v[3]) {
  return Eigen::Vector3d(v[0], v[1], v[2]);
}

}  // namespace

Traverse traverseFromAnnouncements(const std::vector<site_t>& announced, const std::string& root,
                                   std::vector<std::string>& warnings) {
  std::vector<site_t> sites = announced;
  std::sort(sites.begin(), sites.end(),
            [](const site_t& a, const site_t& b) { return a.site_index < b.site_index; });
  Traverse t;
  t.root = root;
  if (!sites.empty()) t.name = sites.front().traverse;
  for (std::size_t k = 0; k < sites.size(); ++k) {
    const site_t& m = sites[k];
    TraverseSite site;
    site.id = m.site_id;
    site.path = "sites/" + m.site_id + "/stream";
    site.dir = root + "/" + site.path;
    site.kind = m.kind == site_t::KIND_STOP ? SiteKind::kStop : SiteKind::kPanorama;
    site.apriori.position_m = vec(m.position_m);
    site.apriori.heading_rad = m.heading_deg * kRadPerDeg;
    if (k > 0 && m.has_odometry) {
      OdometryLeg leg;
      leg.from = m.odometry_from;
      leg.delta_m = vec(m.delta_m);
      leg.delta_heading_rad = m.delta_heading_deg * kRadPerDeg;
      leg.distance_m = m.distance_m;
      leg.sigma_m = vec(m.sigma_m);
      leg.sigma_heading_rad = m.sigma_heading_deg * kRadPerDeg;
      const TraverseSite& previous = t.sites.back();
      if (leg.from != previous.id) {
        // The chain is broken (the site in between was not announced): the leg from the previous announced
        // site is the relative a-priori pose; its sigmas and distance grow with the legs it spans.
        const int legs = std::max(1, m.site_index - sites[k - 1].site_index);
        leg.from = previous.id;
        leg.delta_m = previous.apriori.toSite(site.apriori.position_m);
        leg.delta_heading_rad = site.apriori.heading_rad - previous.apriori.heading_rad;
        leg.sigma_m *= std::sqrt(static_cast<double>(legs));
        leg.sigma_heading_rad *= std::sqrt(static_cast<double>(legs));
        leg.distance_m *= legs;
        warnings.push_back("Site " + m.site_id + ": its odometry is from site " + m.odometry_from +
                           ", which was not announced; its leg from " + previous.id +
                           " is the relative a-priori pose, with sigmas x sqrt(" + std::to_string(legs) +
                           ") and distance x " + std::to_string(legs) + " (estimated).");
      }
      site.odometry = leg;
    } else if (k > 0) {
      warnings.push_back("Site " + m.site_id + " has no odometry leg: its a-priori pose stands alone.");
    }
    t.sites.push_back(site);
  }
  // The odometry model of traverse.json (informative here: the poses use each leg's own sigmas).
  double drift = 0.0, vertical = 0.0, heading = 0.0;
  for (const TraverseSite& s : t.sites) {
    if (!s.odometry || !(s.odometry->distance_m > 0.0)) continue;
    drift =
        std::max(drift, std::max(s.odometry->sigma_m.x(), s.odometry->sigma_m.y()) / s.odometry->distance_m);
    vertical = std::max(vertical, s.odometry->sigma_m.z() / s.odometry->distance_m);
    heading = std::max(heading, s.odometry->sigma_heading_rad);
  }
  t.drift_fraction = drift;
  t.vertical_drift_fraction = vertical;
  t.heading_sigma_rad = heading;
  return t;
}

SitePoseSolution roverPoseSolution(const Traverse& traverse, const std::map<std::string, site_pose_t>& poses) {
  SitePoseSolution out;
  for (const TraverseSite& site : traverse.sites) {
    const auto it = poses.find(site.id);
    if (it == poses.end()) continue;
    const site_pose_t& m = it->second;
    SitePoseEstimate e;
    e.id = site.id;
    e.pose.position_m = Eigen::Vector3d(m.position_m[0], m.position_m[1], m.position_m[2]);
    e.pose.heading_rad = m.heading_deg * kRadPerDeg;
    // [x, y, z, heading] of the 6 x 6 [dp, dtheta]: the rotation about the vertical is dtheta_z.
    const int index[4] = {0, 1, 2, 5};
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) e.covariance(r, c) = m.covariance[6 * index[r] + index[c]];
    e.source = m.status == site_pose_t::STATUS_DATUM ? PoseSource::kFirstSite
               : m.status == site_pose_t::STATUS_TIED ||
                       (m.status == site_pose_t::STATUS_HELD && m.tie_observations > 0)
                   ? PoseSource::kCrossSiteTies
                   : PoseSource::kOdometry;
    e.distance_m = m.distance_m;
    out.sites.push_back(e);
  }
  return out;
}

TraverseResult finishStreamTraverse(const StreamTraverseInputs& in, const TraverseRunOptions& o) {
  std::vector<std::string> warnings = in.site_counts.warnings;
  const Traverse t = traverseFromAnnouncements(in.sites, o.out_dir, warnings);
  if (t.sites.empty()) throw cli::InputError(o.out_dir, "AREOMAP_SITE", "no site announcement was accepted");
  writeTraverse(t, o.out_dir);
  std::vector<SiteOutcome> outcomes;
  for (const TraverseSite& site : t.sites) {
    const std::string dir = o.out_dir + "/sites/" + site.id;
    const auto pass = in.passes.find(site.id);
    if (pass != in.passes.end() && pass->second) {
      outcomes.push_back(siteOutcome(site.id, pass->second));
    } else {
      SiteOutcome s;
      s.id = site.id;
      s.out_dir = dir;
      s.error = "no pair of its panorama arrived intact";
      outcomes.push_back(s);
    }
  }
  const int planned = in.sites.empty() ? 0 : in.sites.front().sites_planned;
  if (static_cast<int>(t.sites.size()) < planned) {
    warnings.push_back("The traverse plans " + std::to_string(planned) + " sites; " +
                       std::to_string(t.sites.size()) + " were announced and accepted.");
  }
  TraverseTruthInput truth;
  if (o.truth_cross_ties && in.truth_traverse.empty())
    throw cli::UsageError("--truth-cross-ties needs --truth TRAVERSE (the traverse folder packed)");
  if (!in.truth_traverse.empty()) {
    const Traverse full = readTraverse(in.truth_traverse);
    truth.folder = full;
    const std::optional<TraverseTruth> all = readTraverseTruth(full.root, full);
    if (all) {
      TraverseTruth subset;
      for (const TraverseSite& site : t.sites) {
        const auto it = std::find(all->ids.begin(), all->ids.end(), site.id);
        if (it == all->ids.end())
          throw cli::InputError(full.root + "/" + kTraverseTruthFile, "sites",
                                "site " + site.id + " of the stream is not in the truth");
        subset.ids.push_back(site.id);
        subset.poses.push_back(all->poses[static_cast<std::size_t>(it - all->ids.begin())]);
      }
      truth.poses = subset;
    }
    const std::string dem = full.root + "/truth/dem.tif";
    if (std::filesystem::exists(dem)) truth.dem_path = dem;
  }
  TraverseStreamFigures figures;
  figures.sites_announced = in.site_counts.sites_announced;
  figures.site_duplicates = in.site_counts.site_duplicates;
  figures.rejected = in.site_counts.rejected;
  if (!in.rover_site_poses.empty()) figures.rover_poses = roverPoseSolution(t, in.rover_site_poses);
  return finishTraverse(t, std::move(outcomes), o, truth, warnings, figures);
}

}  // namespace areomap::traverse
