#include "ground/adjust/DatasetNetwork.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <random>
#include <sstream>

#include "firmware_core/adjust/NetworkBuilder.hpp"
#include "firmware_core/adjust/RigShape.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/dataset/RigEstimate.hpp"
#include "ground/dataset/RigSigmas.hpp"
#include "ground/io/CameraFile.hpp"

namespace areomap::ground {

namespace {

void addCamera(const Dataset& dataset, const ImageRef& ref, const std::string& field, NetworkSource& source) {
  const std::string path = ref.model_path.empty() ? ref.image_path : ref.model_path;
  const CameraModel model = io::readCameraModelForImage(path, ref.image_path, dataset.width, dataset.height);
  PhotogrammetricCamera cam;
  ConversionResidual residual;
  const Status s = cahvorToPhotogrammetric(model, cam, residual);
  if (!ok(s)) {
    throw cli::InputError(path, field, std::string("cannot convert the camera model: ") + statusName(s));
  }
  source.stems.push_back(ref.stem);
  source.apriori_models.push_back(model);
  source.cameras.push_back(cam);
}

}  // namespace

void buildNetwork(const Dataset& dataset, const std::vector<ImageObservation>& observations,
                  const RigChoice& choice, Network& net, NetworkSource& source) {
  net.clear();
  net.rig = RigConstraints{};
  source = NetworkSource{};
  std::map<int, int> sol_index;
  const std::string pano = dataset.root + "/" + kPanoramaFileName;
  for (size_t p = 0; p < dataset.pairs.size(); ++p) {
    const Pair& pr = dataset.pairs[p];
    const std::string field = "pairs[" + std::to_string(p) + "]";
    if (sol_index.count(pr.sol) == 0) {
      if (static_cast<int>(sol_index.size()) >= kMaxSols) {
        throw cli::InputError(pano, field + ".sol", "more than " + std::to_string(kMaxSols) + " sols");
      }
      const int idx = static_cast<int>(sol_index.size());
      sol_index[pr.sol] = idx;
      source.sol_of_index.push_back(pr.sol);
    }
    if (pr.tier < 0 || pr.tier >= kMaxTiers) {
      throw cli::InputError(pano, field + ".tier", "tier outside 0.." + std::to_string(kMaxTiers - 1));
    }
    addCamera(dataset, pr.left, field + ".left.model", source);
    if (pr.right) addCamera(dataset, *pr.right, field + ".right.model", source);
  }
  // The observations as a tie list (image = 2 * pair + side, points in order of first appearance), put
  // into the network pair by pair by the core's NetworkBuilder, as the rover and the ground's own tie run
  // build theirs: an observation enters with the pair of its image.
  std::map<std::string, int> tie_image_of_stem;
  std::vector<int> net_image_of_tie(2 * dataset.pairs.size(), -1);
  for (size_t p = 0, i = 0; p < dataset.pairs.size(); ++p) {
    tie_image_of_stem[dataset.pairs[p].left.stem] = static_cast<int>(2 * p);
    net_image_of_tie[2 * p] = static_cast<int>(i++);
    if (dataset.pairs[p].right) {
      tie_image_of_stem[dataset.pairs[p].right->stem] = static_cast<int>(2 * p + 1);
      net_image_of_tie[2 * p + 1] = static_cast<int>(i++);
    }
  }
  std::map<int64_t, int> point_of_id;
  std::map<std::string, int> unknown_stems;
  std::vector<TiePoint> points;
  std::vector<TieObservation> ties;
  for (const ImageObservation& o : observations) {
    const auto it = tie_image_of_stem.find(o.image);
    if (it == tie_image_of_stem.end()) {
      ++unknown_stems[o.image];
      ++source.dropped_observations;
      continue;
    }
    auto pit = point_of_id.find(o.point);
    if (pit == point_of_id.end()) {
      if (static_cast<int>(points.size()) >= kMaxTiePoints) {
        ++source.dropped_observations;
        continue;
      }
      pit = point_of_id.emplace(o.point, static_cast<int>(points.size())).first;
      points.emplace_back();
      source.point_ids.push_back(o.point);
    }
    TieObservation t;
    t.point = pit->second;
    t.image = it->second;
    t.sample_px = o.sample_px;
    t.line_px = o.line_px;
    ties.push_back(t);
  }
  std::stable_sort(ties.begin(), ties.end(),
                   [](const TieObservation& a, const TieObservation& b) { return a.image / 2 < b.image / 2; });
  auto builder = std::make_unique<NetworkBuilder>();  // fixed tables, too large for the stack
  builder->reset();
  builder->sigma_px = choice.sigma_px;
  TieList list{points.data(), static_cast<int32_t>(points.size()), ties.data(), 0, 0};
  for (size_t p = 0; p < dataset.pairs.size(); ++p) {
    const Pair& pr = dataset.pairs[p];
    while (list.observation_count < static_cast<int32_t>(ties.size()) &&
           ties[static_cast<std::size_t>(list.observation_count)].image / 2 == static_cast<int32_t>(p))
      ++list.observation_count;
    list.pair_count = static_cast<int32_t>(p) + 1;
    const int left = net_image_of_tie[2 * p];
    const CameraModel* right = pr.right ? &source.apriori_models[static_cast<std::size_t>(left) + 1] : nullptr;
    int32_t failed = 0;
    const Status s = builder->syncPair(list, sol_index[pr.sol], pr.tier, source.apriori_models[left], right,
                                       net, failed);
    if (!ok(s)) {
      throw cli::InputError(pano, "pairs[" + std::to_string(p) + "]",
                            std::string("cannot add the pair: ") + statusName(s));
    }
    source.dropped_observations += failed;
  }
  for (const auto& [stem, count] : unknown_stems) {
    source.warnings.push_back(std::to_string(count) + " observations name image '" + stem +
                              "', which is not in the dataset; they were ignored.");
  }
  int32_t failed = 0;
  (void)net.triangulateAll(failed);
  if (failed > 0) {
    source.warnings.push_back(
        std::to_string(failed) +
        " tie points could not be triangulated from the a-priori EO (fewer than two rays "
        "or parallel rays); they are left out.");
  }
  const RigEstimate rig = estimateRig(dataset.rig, source.sol_of_index, net, choice.fido);
  source.estimated.insert(source.estimated.end(), rig.estimated.begin(), rig.estimated.end());
  source.warnings.insert(source.warnings.end(), rig.warnings.begin(), rig.warnings.end());
  source.rig_fit_rms_m = rig.fit_rms_m;
  // The rule of firmware_core/adjust/RigShape.hpp (the ground pass, areomap-ties and the rover switch to the
  // FIDO model by it; here the user's flags choose the model, so it only warns).
  const RigShape shape = checkRigShape(net);
  if (choice.gimbal && !shape.one_point) {
    std::ostringstream w;
    w << "Eq. 3 fitted to the a-priori cameras misses them by " << shape.fit_rms_m * 1000.0
      << " mm RMS (a rig that turns about one point: at most " << shape.threshold_m * 1000.0
      << " mm): the mast does not turn the cameras about one point. For a mast whose tilt axis is off its "
         "pan axis use --fido --no-gimbal (a virtual spin centre per tier).";
    source.warnings.push_back(w.str());
  }
  net.rig.use_gimbal = choice.gimbal;
  net.rig.use_base = choice.base;
  net.rig.use_spin_centre = choice.fido;
  net.rig.use_lr_distance = choice.fido;
  net.rig.use_datum_prior = choice.datum_prior;
}

std::vector<ImageObservation> noisyTruthObservations(const Dataset& dataset, double noise_px, uint64_t seed) {
  std::vector<ImageObservation> observations =
      readObservationsCsv(dataset.root + "/" + kTruthObservationsFile);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (ImageObservation& o : observations) {
    o.sample_px += noise_px * gauss(rng);
    o.line_px += noise_px * gauss(rng);
  }
  return observations;
}

NetworkTruth loadNetworkTruth(const Dataset& dataset, const NetworkSource& source, bool with_points) {
  NetworkTruth truth;
  for (const std::string& stem : source.stems) {
    const std::string path = dataset.root + "/" + kTruthModelsFolder + "/" + stem + ".cahvor";
    if (!std::filesystem::exists(path)) return NetworkTruth{};
    PhotogrammetricCamera cam;
    ConversionResidual residual;
    if (!ok(cahvorToPhotogrammetric(io::readCameraModelFile(path, dataset.width, dataset.height), cam,
                                    residual))) {
      throw cli::InputError(path, "model", "cannot convert the true model");
    }
    truth.centres.push_back(cam.eo.centre_m);
    truth.rotations.push_back(cam.m);
  }
  truth.available = true;
  const std::string points_path = dataset.root + "/" + kTruthPointsFile;
  if (with_points && std::filesystem::exists(points_path)) {
    std::map<int64_t, Vec3> truth_of_id;
    for (const CheckPoint& c : readPointsCsv(points_path)) truth_of_id[c.point] = c.site_m;
    for (int64_t id : source.point_ids) {
      const auto it = truth_of_id.find(id);
      truth.points.push_back(it != truth_of_id.end() ? it->second : Vec3::Constant(std::nan("")));
    }
  }
  return truth;
}

}  // namespace areomap::ground
