// The rover's tie-point pipeline (firmware_core/match PanoramaMatcher) run on a loaded panorama on the
// ground (io::Panorama: each image as 8-bit grey with its a-priori model): pairs in panorama.json order,
// the observations named by image stem, in full-resolution pixels of any image size (images beyond the
// matcher's capacity are matched binned and refined at full resolution: FullResolutionTies.hpp).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/adjust/NetworkBuilder.hpp"
#include "firmware_core/match/PanoramaMatcher.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/io/Panorama.hpp"
#include "ground/ties/FullResolutionTies.hpp"

namespace areomap {

struct TieRun {
  std::vector<ImageObservation> observations;  // point, image stem, sample, line, kind
  std::vector<Eigen::Vector3d> points_m;       // a-priori ground position per point id
  std::vector<PairTieReport> reports;          // per pair
  std::vector<std::string> stems;              // image index (2 * pair + side) -> stem ("" when absent)
  int intra_observations = 0;
  int inter_observations = 0;
  double seconds = 0.0;
  int32_t binning = 1;  // the factor the images were binned by for the matcher (1: full resolution)
  RefineCounts refine;  // the full-resolution refinement (binning > 1)
};

// The adjustment network built alongside (NetworkBuilder after every pair).
struct TieNetwork {
  std::unique_ptr<Network> net = std::make_unique<Network>();
  std::unique_ptr<NetworkBuilder> builder = std::make_unique<NetworkBuilder>();
  std::vector<int> sol_of_index;              // network sol index -> panorama.json sol
  std::vector<std::string> stem_of_image;     // network image -> stem
  std::vector<CameraModel> apriori_of_image;  // network image -> a-priori model
  int failed_observations = 0;
};

// Runs the matcher on every pair. `progress` prints a line per pair on stderr; `network` (optional) is
// built from the ties (full-resolution pixels, a-priori models). Throws cli::InputError for images or models
// that the matcher or the network refuses.
TieRun runTiePoints(const io::Panorama& panorama, bool progress, TieNetwork* network = nullptr);

// DIR/tiepoints.csv (point,image,sample_px,line_px,kind).
void writeTiePoints(const std::string& out_dir, const TieRun& run);
// DIR/overlays/<stem>.png: the image with blue crosses on intra-stereo and red on inter-stereo observations.
void writeOverlays(const std::string& out_dir, const io::Panorama& panorama, const TieRun& run);

}  // namespace areomap
