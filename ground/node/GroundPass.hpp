// The ground's work at the end of a panorama, on a dataset folder: either the one given
// (`areomap-ground --dataset DIR`) or the one the ground wrote from the camera stream (full-resolution
// images as decoded from the stream's JPEGs).
//
//   1. tie points: the rover's own (AREOMAP_TIEPOINTS) when they arrived complete -- the rover's final EO
//      arrived, no TIEPOINTS message was lost, and one came for every pair the ground kept -- so the
//      integrated reference adjusts the very observations the rover adjusted; otherwise (no rover, a log
//      of the camera stream alone, lost messages) the rover's matcher (firmware_core/match, via ground/ties
//      runTiePoints) run again on the ground's images, with a warning in report.json saying why;
//   2. the fast adjustment (its outlier rejection and method-1 figures), then the INTEGRATED adjustment
//      (Ceres sparse Schur, ground/adjust) from the a-priori EO with the same rejections: the reference;
//      between them the hold-out check (ground/ties/HoldOutCheck.hpp) rejects wrong ties, and every pair
//      whose cameras the adjustment does not improve on held-out ties keeps its a-priori models;
//   3. products: models/<stem>.cahvor (integrated), eo.csv, tiepoints.csv, rover_models/<stem>.cahvor (the
//      rover's last EO), rover_tiepoints.csv (the rover's TIEPOINTS), report.json with `stream`, `rover`
//      (incl. eo_vs_ground_px) and `truth` when truth exists; then the products hook (DEM, ortho, previews:
//      ground/products) when one is set.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "areomap/eo_solution_t.hpp"
#include "areomap/product_t.hpp"
#include "areomap/rover_status_t.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "ground/adjust/AdjustProducts.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/io/Panorama.hpp"
#include "ground/node/StreamCollector.hpp"
#include "ground/ties/HoldOutCheck.hpp"

namespace areomap::ground {

// What the rover sent (absent when it did not run or nothing arrived).
struct RoverInputs {
  std::optional<eo_solution_t> eo;
  std::optional<rover_status_t> status;
  int32_t tie_messages = 0;
  int32_t tie_observations = 0;
  int32_t dem_messages = 0;
  std::vector<ImageObservation> ties;  // written as rover_tiepoints.csv
  std::set<int32_t> tie_pairs;         // pairs that a TIEPOINTS message came for
  int32_t tie_messages_missing = 0;    // TIEPOINTS sequence numbers never received
  bool finished = false;               // the rover's final EO (or FINISHED status) arrived
  std::vector<std::string> warnings;
};

// Handed to the products hook after the adjustment products are written.
struct ProductContext {
  const io::Panorama* panorama = nullptr;  // the dataset with its images and a-priori models, loaded once
  std::string out_dir;
  const Network* net = nullptr;                         // the integrated solution
  const std::vector<std::string>* stems = nullptr;      // per network image
  const std::vector<CameraModel>* apriori = nullptr;    // per network image
  const std::vector<ImageObservation>* ties = nullptr;  // tie observations (image = stem)
  AdjustReport* report = nullptr;  // add stage timings, warnings, truth.dem_rmse_m (written after the hook)
  std::string truth_root;          // the folder holding truth/ ("" when none)
  // The hook appends one message per product it could not write (naming the file; ProductsResult::
  // write_errors); they end up in GroundPassResult::write_errors.
  std::vector<std::string>* write_errors = nullptr;
};
using ProductsHook = std::function<void(const ProductContext&)>;

struct GroundPassOptions {
  std::string out_dir;
  // A dataset folder holding truth/ (or a truth folder itself); "" = the dataset's own truth/ if any.
  std::string truth_dir;
  bool progress = true;
  bool use_rover_ties = true;  // false: always run the matcher on the ground's images
  ProductsHook products_hook;  // unset: only the adjustment products
};

struct ManifestEntry {
  std::string name;  // relative to the out dir
  int64_t bytes = 0;
  std::string sha256_hex;
};

struct GroundPassResult {
  int32_t pairs = 0;
  int32_t images = 0;
  int32_t points = 0;
  int32_t intra_observations = 0;
  int32_t inter_observations = 0;
  int32_t rejected_observations = 0;
  double method1_before_px = 0.0;  // mean distance
  double method1_after_px = 0.0;   // integrated
  double method1_fast_px = 0.0;    // fast adjustment
  int32_t fast_sweeps = 0;
  int32_t integrated_iterations = 0;
  double rms_px = 0.0;
  bool rover_ties_used = false;  // the adjusted ties are the rover's (else the ground's own matching)
  // The hold-out check of the adjustment per pair (ground/ties/HoldOutCheck.hpp): wrong ties rejected
  // (counted in rejected_observations), pairs without evidence of improvement back to their a-priori models.
  HoldOutResult holdout;
  std::optional<double> truth_eo_before_px, truth_eo_after_px, truth_eo_fast_px;
  std::optional<double> rover_vs_ground_px;  // rover's last EO against the integrated solution
  std::optional<double> fast_vs_ground_px;   // the ground's own fast solution against it
  std::vector<std::pair<std::string, double>> seconds;
  std::vector<std::string> warnings;
  std::vector<ManifestEntry> files;
  // Products that could not be written (full disk, folder not writable), one message each naming the file.
  // The pass goes on with the other products; areomap-ground then exits 1 (DESIGN.md exit codes).
  std::vector<std::string> write_errors;
};

// Whether the rover's tie points can stand for the panorama's: "" when they can, else the reason (also
// when the rover binned frames above its capacity: the ground then matches at full resolution).
std::string roverTiesIncomplete(const Dataset& dataset, const RoverInputs& rover);

// Runs the pass and writes the products. Throws cli::InputError on bad input or an unsolvable network; a
// product that cannot be written does not stop the pass: it is named in `write_errors` (and report.json's
// warnings when report.json itself can be written). The images and a-priori models are read once, when a
// stage first needs them, or come from `loaded` (the same dataset, already loaded: a stream's images).
GroundPassResult runGroundPass(const Dataset& dataset, const GroundPassOptions& options,
                               const StreamCounts* stream, const RoverInputs* rover,
                               const io::Panorama* loaded = nullptr);

// RMS pixel-equivalent difference (f x (angle + |dC| / 5 m)) between the rover's EO and the network's
// current EO over the images both have (by stem), after removing their best-fit common rotation about
// `gimbal_m`. nullopt when no image is common.
std::optional<double> eoDifferencePx(const eo_solution_t& rover, const Network& net,
                                     const std::vector<std::string>& stems, const Vec3& gimbal_m,
                                     int32_t* compared = nullptr);

// Every file under out_dir (recursively, sorted), except `exclude_prefix` ("" = none) and the node's
// recording (kRecordingName at the top).
std::vector<ManifestEntry> buildManifest(const std::string& out_dir, const std::string& exclude_prefix = "");
product_t manifestMessage(const std::string& panorama, const std::string& out_dir,
                          const std::vector<ManifestEntry>& files, int64_t sequence);

}  // namespace areomap::ground
