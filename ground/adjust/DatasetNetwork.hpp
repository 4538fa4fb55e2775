// From a dataset (panorama.json + a-priori models) and image observations (stem, measured pixel) to the
// adjustment Network: models converted to the photogrammetric form, measured pixels mapped once through the
// exact CAHVOR inverse to ideal pixels, points triangulated from the a-priori EO, and the rig constants taken
// from panorama.json or, where missing, estimated from the a-priori models (ground/dataset/RigEstimate.hpp,
// reported in `estimated`).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/camera/CameraConversion.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/TruthFiles.hpp"

namespace areomap::ground {

struct NetworkSource {
  std::vector<std::string> stems;              // per network image
  std::vector<CameraModel> apriori_models;     // per network image
  std::vector<PhotogrammetricCamera> cameras;  // per network image, a-priori
  std::vector<int64_t> point_ids;              // per network point
  std::vector<int> sol_of_index;               // network sol index -> dataset sol number
  std::vector<std::string> estimated;          // sentences: which rig values were estimated and how
  std::vector<std::string> warnings;           // dropped observations, unknown stems, ...
  int dropped_observations = 0;
  // The RMS (m) by which a fitted gimbal centre and camera offsets miss the a-priori camera centres; 0 when
  // the dataset gives them all.
  double rig_fit_rms_m = 0.0;
};

struct RigChoice {
  bool gimbal = true;
  bool base = true;
  bool fido = false;  // virtual spin centre per tier + camera-to-centre and left-right distances
  bool datum_prior = true;
  double sigma_px = 0.3;  // a-priori sigma of every image observation
};

// Loads the models and fills `net` (cleared first). Throws cli::InputError naming the file and field.
void buildNetwork(const Dataset& dataset, const std::vector<ImageObservation>& observations,
                  const RigChoice& choice, Network& net, NetworkSource& source);

// DATASET/truth/observations.csv with Gaussian noise of `noise_px` per coordinate (seeded).
std::vector<ImageObservation> noisyTruthObservations(const Dataset& dataset, double noise_px, uint64_t seed);

// The true EO of every network image (from truth/models/<stem>.cahvor) and, when `with_points` and
// truth/points.csv exist, the true position of every network point by point id (NaN when unknown).
struct NetworkTruth {
  bool available = false;  // false when any true model is missing
  std::vector<Vec3> centres;
  std::vector<Mat3> rotations;
  std::vector<Vec3> points;  // empty when not available
};
NetworkTruth loadNetworkTruth(const Dataset& dataset, const NetworkSource& source, bool with_points);

}  // namespace areomap::ground
