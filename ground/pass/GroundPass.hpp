// The ground's work at the end of a panorama, on a dataset: a folder (`areomap-ground --dataset DIR`, each
// site of areomap-traverse) or what the node received from the camera stream (full-resolution images as
// decoded from the stream's JPEGs, handed over in memory).
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
//      rover's last EO), rover_tiepoints.csv (the rover's TIEPOINTS); with `products` the DEM, ortho and
//      previews (ground/products, PassProducts.hpp); last report.json with `stream`, `rover` (incl.
//      eo_vs_ground_px) and `truth` when truth exists, made in memory and written once.
//
// The pass is a call that returns its data (SitePass below): the node and the traverse go on from that
// value, not from the files it wrote.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "areomap/eo_solution_t.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "ground/adjust/AdjustProducts.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/DemRaster.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/io/Panorama.hpp"
#include "ground/pass/PassInputs.hpp"
#include "ground/ties/HoldOutCheck.hpp"

namespace areomap::ground {

struct GroundPassOptions {
  std::string out_dir;
  // A dataset folder holding truth/ (or a truth folder itself); "" = the dataset's own truth/ if any.
  std::string truth_dir;
  bool progress = true;
  bool use_rover_ties = true;  // false: always run the matcher on the ground's images
  bool products = false;       // the DEM, ortho, previews (ground/products); false: the adjustment's alone
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
  // Products that could not be written (full disk, folder not writable), one message each naming the file.
  // The pass goes on with the other products; areomap-ground then exits 1 (DESIGN.md exit codes).
  std::vector<std::string> write_errors;
};

// Whether the rover's tie points can stand for the panorama's: "" when they can, else the reason (also
// when the rover binned frames above its capacity: the ground then matches at full resolution).
// One site's pass as data: what it was given, what it solved and what it made (the same as its files).
struct SitePass {
  std::string out_dir;
  Dataset dataset;
  std::shared_ptr<const io::Panorama> panorama;  // its images and a-priori models (null: never loaded)
  std::shared_ptr<const Network> network;        // the integrated solution (null: rebuilt from files)
  std::vector<std::string> stems;                // per network image
  std::vector<CameraModel> apriori;              // per network image
  std::vector<CameraModel> adjusted;             // per network image: models/<stem>.cahvor
  std::vector<ImageObservation> ties;            // the adjusted tie observations (image = stem)
  // The products (absent without products, or when the pass made none): dem.tif, dem_sigma.tif, and
  // ortho.tif as grey values on its grid (nodata 0).
  std::optional<DemGrid> dem, dem_sigma, ortho;
  AdjustReport report;       // report.json's figures (method 1-3, truth, warnings, timings)
  GroundPassResult summary;  // the console's figures and the products not written
  // The a-priori model and the adjusted model of a stem, nullptr when the network has no such image.
  const CameraModel* adjustedOf(const std::string& stem) const;
  const CameraModel* aprioriOf(const std::string& stem) const;
};

std::string roverTiesIncomplete(const Dataset& dataset, const RoverInputs& rover);

// Runs the pass, writes the products and returns them as data. Throws cli::InputError on bad input or an
// unsolvable network; a product that cannot be written does not stop the pass: it is named in
// `summary.write_errors` (and report.json's warnings when report.json itself can be written). The images
// and a-priori models are read once, when a stage first needs them, or come from `loaded` (the same
// dataset, already loaded: a stream's images).
SitePass runGroundPass(const Dataset& dataset, const GroundPassOptions& options, const StreamCounts* stream,
                       const RoverInputs* rover, std::shared_ptr<const io::Panorama> loaded = nullptr);

// RMS pixel-equivalent difference (f x (angle + |dC| / 5 m)) between the rover's EO and the network's
// current EO over the images both have (by stem), after removing their best-fit common rotation about
// `gimbal_m`. nullopt when no image is common.
std::optional<double> eoDifferencePx(const eo_solution_t& rover, const Network& net,
                                     const std::vector<std::string>& stems, const Vec3& gimbal_m,
                                     int32_t* compared = nullptr);

}  // namespace areomap::ground
