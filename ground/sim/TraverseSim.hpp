// A simulated multi-site traverse (`areomap-sim --preset traverse`): one continuous terrain under
// a winding path of sites (ground/sim/TraversePlan.hpp), a complete single-site dataset per site and the
// traverse description. Layout (docs/traverse.md "traverse.json"):
//
//   DIR/traverse.json               the sites in driving order, their a-priori poses, the odometry legs
//   DIR/sites/<id>/                 one dataset per site, exactly as `areomap-sim --preset navcam` writes it
//                                   (panorama.json, images/, models/, truth/), in that site's own frame
//   DIR/truth/traverse.json         the true site poses in the traverse frame (and attitudes, sloped ground)
//   DIR/truth/dem.tif               the terrain in the traverse frame (coarser cell, kTraverseDemCellM)
//
// Frames (ground/dataset/Traverse.hpp): a site's frame is the rover's own, levelled, origin at the site;
// its a-priori models carry only the pointing errors and its truth/ files are in the same frame, so every
// single-site tool and truth check runs on DIR/sites/<id> unchanged and sees no odometry error. The
// odometry error is between the a-priori poses (traverse.json) and the true ones (truth/traverse.json):
// a site point p lies at truth.toTraverse(p) in the traverse frame, the rover believes apriori.toTraverse(p).
// On sloped ground (traverse.max_slope_deg > 0) each rover stands tilted in its levelled site frame
// (TraversePlan.hpp): its a-priori models also carry the IMU's attitude error (traverse.json
// sites[].attitude), the truth the true attitude (truth/traverse.json).
//
// The terrain: the fine grid (the camera preset's cell, rocks, craters, every relief octave) is a square
// about the middle of the path's bounding box reaching `terrain_margin_m` beyond the outermost site; the
// coarse grid continues the relief Terrain::kMinCoverHalfM beyond it. Rock sizes, the rock-free footprint,
// crater placement and the texture's fading go by the range to the nearest site, so that each site sees
// the statistics of a single-site scene.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "ground/sim/SimConfig.hpp"
#include "ground/sim/Terrain.hpp"
#include "ground/sim/TraversePlan.hpp"

namespace areomap::sim {

constexpr double kTraverseDemCellM = 0.1;  // DIR/truth/dem.tif: the whole terrain, traverse frame

struct TraverseSimConfig {
  SimConfig site;  // camera, head, plan, terrain statistics and rendering of every site (--camera preset)
  TraverseSettings traverse;
  double terrain_margin_m = 30.0;  // fine grid beyond the outermost site (--extent-m)
  uint64_t seed = 1;
};

struct TraverseSimOptions {
  bool images = true;
  // Progress: a line per stage, and (site id, images done, images of the site) after each image.
  std::function<void(const std::string&)> on_stage;
  std::function<void(const std::string&, int, int)> on_image;
};

// The camera presets a traverse takes its sites from ("navcam", "tiny", ...): presetConfig(name) with the
// site-frame defaults; throws cli::UsageError for an unknown one.
TraverseSimConfig traversePreset(const std::string& camera_preset);

// The configuration of the shared terrain for a plan: the site preset's statistics, the fine square about
// the middle of the path, the rovers' positions.
SimConfig traverseTerrainConfig(const TraverseSimConfig& config, const TraversePlan& plan);

// A traversing stop's camera plan (--stop-spacing-m): each tier of the site preset that is not a single
// left image keeps its tilt and pan step, as few pairs as cover a forward sector of kStopSectorDeg (field
// of view included), centred on the rover's heading (pan 0 in the site frame).
constexpr double kStopSectorDeg = 90.0;
SimConfig stopConfig(const SimConfig& site);

// The seed of site `index` (its pointing errors, check points and image noise).
uint64_t traverseSiteSeed(uint64_t seed, int index);

// Builds the terrain and the plan and writes the whole layout. Throws cli::UsageError for an impossible
// plan, DatasetError for an unwritable folder.
TraversePlan writeTraverseDataset(const TraverseSimConfig& config, const std::string& out_dir,
                                  const TraverseSimOptions& options);

}  // namespace areomap::sim
