#include "ground/sim/TraverseSim.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "ground/dataset/DemRaster.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/sim/Noise.hpp"
#include "ground/sim/SimGeometry.hpp"
#include "ground/sim/SimWriter.hpp"

namespace areomap::sim {
namespace {

constexpr uint64_t kSiteSeedStream = 0x517e;
constexpr double kMaxTerrainMarginM = 30.0;  // the default fine margin at most (navcam's top rows see ~25 m)
constexpr uint64_t kSlopeStream = 0x5109e;   // where the swells' steepest circle crosses the path

}  // namespace

TraverseSimConfig traversePreset(const std::string& camera_preset) {
  TraverseSimConfig c;
  c.site = presetConfig(camera_preset);
  c.terrain_margin_m = std::min(c.site.half_extent_m, kMaxTerrainMarginM);
  return c;
}

SimConfig traverseTerrainConfig(const TraverseSimConfig& config, const TraversePlan& plan) {
  Eigen::Vector2d lo(0.0, 0.0), hi(0.0, 0.0);
  SimConfig t = config.site;
  t.seed = config.seed;
  t.rover_xy_m.clear();
  for (const SitePose& pose : plan.truth) {
    const Eigen::Vector2d xy = pose.position_m.head<2>();
    lo = lo.cwiseMin(xy);
    hi = hi.cwiseMax(xy);
    t.rover_xy_m.push_back(xy);
  }
  const double path_half_m = 0.5 * (hi - lo).maxCoeff();
  t.terrain_centre_m = 0.5 * (lo + hi);
  t.half_extent_m = path_half_m + config.terrain_margin_m;
  t.cover_half_extent_m = path_half_m + Terrain::kMinCoverHalfM;
  t.max_slope_deg = config.traverse.max_slope_deg;
  if (t.max_slope_deg > 0.0) {
    // The swells' centre a quarter wavelength from a panorama site (drawn from the seed) in a drawn
    // direction: that site stands where the swells are steepest (max_slope_deg), the others where the
    // circles about the centre put them.
    std::vector<std::size_t> panoramas;
    for (std::size_t k = 0; k < plan.kinds.size(); ++k) {
      if (plan.kinds[k] == SiteKind::kPanorama) panoramas.push_back(k);
    }
    const uint64_t h = hash3(config.seed, kSlopeStream, 0);
    const std::size_t pick =
        std::min(panoramas.size() - 1, static_cast<std::size_t>(unit(mix64(h + 1)) * panoramas.size()));
    const double azimuth = 2.0 * M_PI * unit(mix64(h + 2));
    t.slope_centre_m = plan.truth[panoramas[pick]].position_m.head<2>() -
                       0.25 * kSlopeWavelengthM * Eigen::Vector2d(std::cos(azimuth), std::sin(azimuth));
  }
  return t;
}

SimConfig stopConfig(const SimConfig& site) {
  SimConfig c = site;
  c.tiers.clear();
  for (const TierPlan& tier : site.tiers) {
    if (tier.left_only || tier.pan_step_deg <= 0.0) continue;
    TierPlan t = tier;
    t.pairs = 1 + static_cast<int>(
                      std::ceil(std::max(0.0, kStopSectorDeg - site.hfov_deg) / t.pan_step_deg - 1e-9));
    t.pan0_deg = -0.5 * (t.pairs - 1) * t.pan_step_deg;
    c.tiers.push_back(t);
  }
  return c;
}

uint64_t traverseSiteSeed(uint64_t seed, int index) {
  return hash3(seed, kSiteSeedStream, index);
}

TraversePlan writeTraverseDataset(const TraverseSimConfig& config, const std::string& out,
                                  const TraverseSimOptions& options) {
  auto stage = [&](const std::string& text) {
    if (options.on_stage) options.on_stage(text);
  };
  validateTraverse(config.traverse);
  validatePlan(config.site);
  // The horizontal path does not depend on the ground: the terrain is laid out from it, then the heights.
  const TraversePlan flat = planTraverse(config.traverse, config.seed);
  const SimConfig terrain_config = traverseTerrainConfig(config, flat);
  validatePlan(terrain_config);
  std::ostringstream what;
  what << "building the terrain: a " << std::lround(2.0 * terrain_config.half_extent_m) << " m square of "
       << terrain_config.cell_m << " m cells about (" << std::lround(terrain_config.terrain_centre_m.x())
       << ", " << std::lround(terrain_config.terrain_centre_m.y()) << ") m; path "
       << std::lround(flat.distanceM()) << " m";
  stage(what.str());
  const Terrain terrain = Terrain::build(terrain_config);
  stage("terrain " + std::to_string(terrain.nodes()) + " x " + std::to_string(terrain.nodes()) + " nodes, " +
        std::to_string(terrain.rockCount()) + " rocks, " + std::to_string(terrain.craterCount()) +
        " craters");
  const TraversePlan plan =
      planTraverse(config.traverse, config.seed, [&](double x, double y) { return terrain.elevation(x, y); });

  Traverse traverse;
  traverse.root = out;
  traverse.name = "sim-traverse-" + std::to_string(config.seed);
  traverse.drift_fraction = config.traverse.drift_fraction;
  traverse.vertical_drift_fraction = config.traverse.vertical_drift_fraction;
  traverse.heading_sigma_rad = config.traverse.heading_drift_deg * M_PI / 180.0;
  TraverseTruth truth;
  truth.max_slope_deg = config.traverse.max_slope_deg;
  for (std::size_t k = 0; k < plan.truth.size(); ++k) {
    const int index = static_cast<int>(k);
    const bool stop = plan.kinds[k] == SiteKind::kStop;
    SimConfig site_config = stop ? stopConfig(terrain_config) : terrain_config;
    site_config.seed = traverseSiteSeed(config.seed, index);
    const std::optional<RoverStance> stance =
        plan.stances.empty() ? std::nullopt : std::optional<RoverStance>(plan.stances[k]);
    SimGeometry g = makeGeometry(site_config, terrain, plan.truth[k], stance);
    g.dem_half_extent_m = Terrain::kMinCoverHalfM;
    g.name = traverse.name + "-" + plan.ids[k];
    stage(plan.ids[k] + (stop ? " (a traversing stop, " : " (") + std::to_string(k + 1) + " of " +
          std::to_string(plan.truth.size()) + "): " + std::to_string(g.cameras().size()) + " images, " +
          std::to_string(g.points.size()) + " check points");
    if (static_cast<int>(g.points.size()) < site_config.check_points) {
      stage("warning: " + plan.ids[k] + ": only " + std::to_string(g.points.size()) + " of " +
            std::to_string(site_config.check_points) + " check points are seen by two or more images");
    }
    if (const int beyond = camerasSeeingBeyondTerrain(g, terrain); beyond > 0) {
      stage("warning: " + plan.ids[k] + ": " + std::to_string(beyond) +
            " image(s) see ground beyond the terrain grid (raise --extent-m or tilt down)");
    }
    WriteOptions write;
    write.images = options.images;
    if (options.on_image)
      write.on_image = [&](int done, int total) { options.on_image(plan.ids[k], done, total); };
    const std::string path = "sites/" + plan.ids[k];
    writeSimDataset(g, terrain, out + "/" + path, write);

    TraverseSite site;
    site.id = plan.ids[k];
    site.path = path;
    site.dir = out + "/" + path;
    site.kind = plan.kinds[k];
    site.apriori = plan.apriori[k];
    if (k > 0) site.odometry = plan.legs[k - 1];
    if (stance) {
      site.attitude = stance->apriori;
      site.attitude_sigma_rad = config.traverse.tilt_sigma_deg * M_PI / 180.0;
      truth.attitudes.push_back(stance->truth);
    }
    traverse.sites.push_back(site);
    truth.ids.push_back(plan.ids[k]);
    truth.poses.push_back(plan.truth[k]);
  }
  writeTraverse(traverse, out);
  writeTraverseTruth(truth, out);
  writeDemGeoTiff(out + "/" + kTruthDemFile, terrain.demInFrame(SitePose{}, terrain_config.terrain_centre_m,
                                                                terrain.halfExtentM(), kTraverseDemCellM));
  return plan;
}

}  // namespace areomap::sim
