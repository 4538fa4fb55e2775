#include "ground/node/GroundPass.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "firmware_core/adjust/Datum.hpp"
#include "firmware_core/adjust/FastAdjuster.hpp"
#include "firmware_core/adjust/Precision.hpp"
#include "firmware_core/camera/Photogrammetric.hpp"
#include "ground/adjust/AdjustProducts.hpp"
#include "ground/adjust/DatasetNetwork.hpp"
#include "ground/adjust/IntegratedAdjuster.hpp"
#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/node/EventRecorder.hpp"
#include "ground/node/Sha256.hpp"
#include "ground/ties/TieAdjust.hpp"
#include "ground/ties/TieRunner.hpp"
#include "msgs/adapters/MessageAdapters.hpp"

namespace areomap::ground {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

constexpr double kNominalRange_m = 5.0;  // pixel equivalent of EO differences (as in the adjust reports)

struct EoSet {
  std::vector<Vec3> centers;
  std::vector<Mat3> rotations;
  std::vector<double> f_px;
};

EoSet currentEo(const Network& net) {
  EoSet s;
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    s.centers.push_back(net.image(i).center_m);
    s.rotations.push_back(net.image(i).m);
    s.f_px.push_back(net.image(i).io.f_px);
  }
  return s;
}

// RMS pixel equivalent of `est` against `ref` after the best-fit common rotation about gimbal_m.
double alignedDifferencePx(const EoSet& est, const EoSet& ref, const Vec3& gimbal_m) {
  const int32_t n = static_cast<int32_t>(est.centers.size());
  if (n == 0) return 0.0;
  const Mat3 r = commonRotation(est.rotations.data(), ref.rotations.data(), n);
  double sum = 0.0;
  for (int32_t i = 0; i < n; ++i) {
    Mat3 m;
    m.noalias() = est.rotations[i] * r.transpose();
    Vec3 c = gimbal_m;
    c.noalias() += r * (est.centers[i] - gimbal_m);
    const double px = eoPixelEquivalent(ref.f_px[i], c - ref.centers[i], rotationAngle(m, ref.rotations[i]),
                                        kNominalRange_m);
    sum += px * px;
  }
  return std::sqrt(sum / n);
}

json differences(const ImageDifferences& d) {
  return json{{"x", d.x}, {"y", d.y}, {"dist", d.dist}};
}

// The folder that holds truth/ for this pass ("" when none).
std::string truthRoot(const Dataset& dataset, const std::string& truth_dir) {
  if (!truth_dir.empty()) {
    if (fs::exists(truth_dir + "/truth/models")) return truth_dir;
    if (fs::path(truth_dir).filename() == "truth" && fs::exists(truth_dir + "/models")) {
      return fs::path(truth_dir).parent_path().string();
    }
    throw cli::InputError(truth_dir, "truth/models",
                          "no true models there (give a dataset folder with truth/)");
  }
  return fs::exists(dataset.root + "/truth/models") ? dataset.root : std::string();
}

// The rover's tie observations as the pass's tie run and network (cameras from the dataset's models).
TieRun roverTieRun(const Dataset& dataset, const RoverInputs& rover, TieNetwork& network,
                   std::vector<std::string>& warnings) {
  const double start = cli::nowSeconds();
  NetworkSource source;
  buildNetwork(dataset, rover.ties, RigChoice{}, *network.net, source);
  for (const std::string& w : source.warnings) warnings.push_back("The rover's tie points: " + w);
  network.sol_of_index = source.sol_of_index;
  network.stem_of_image = source.stems;
  network.apriori_of_image = source.apriori_models;
  TieRun run;
  run.observations = rover.ties;
  for (const ImageObservation& o : rover.ties)
    (o.kind == "inter" ? run.inter_observations : run.intra_observations) += 1;
  run.seconds = cli::nowSeconds() - start;
  return run;
}

void writeNodeReport(const std::string& out, const AdjustReport& report, const StreamCounts* stream,
                     const RoverInputs* rover, const json& rover_json, const AdjustOutcome& fast,
                     const GroundPassResult& result);

// A product that could not be written (full disk, folder not writable: `error` names the file): recorded,
// and the pass goes on with the other products.
void recordWriteError(GroundPassResult& result, AdjustReport& report, const std::string& error) {
  cli::warn("not written: " + error);
  result.write_errors.push_back(error);
  report.warnings.push_back("Not written: " + error);
}

// Runs one product writer; a failure (the writers throw an error naming the file) is recorded.
void writeOrRecord(GroundPassResult& result, AdjustReport& report, const std::function<void()>& write) {
  try {
    write();
  } catch (const std::exception& e) {
    recordWriteError(result, report, e.what());
  }
}

}  // namespace

std::string roverTiesIncomplete(const Dataset& dataset, const RoverInputs& rover) {
  if (rover.ties.empty()) return "none arrived";
  if (!rover.finished) return "the rover's final EO did not arrive";
  if (rover.tie_messages_missing > 0) {
    return std::to_string(rover.tie_messages_missing) + " AREOMAP_TIEPOINTS message(s) were lost";
  }
  std::string missing;
  for (const Pair& p : dataset.pairs) {
    if (rover.tie_pairs.count(p.id) == 0) missing += (missing.empty() ? "" : ", ") + std::to_string(p.id);
  }
  if (!missing.empty()) return "none came for pair(s) " + missing;
  if (rover.status && rover.status->pairs_binned > 0) {
    // The rover's ties are in the frames' pixels, at the precision of its binned matching; the ground holds
    // the full-resolution frames and refines its own binned matches on them (FullResolutionTies.hpp).
    return "the rover matched " + std::to_string(rover.status->pairs_binned) +
           " pair(s) on frames binned to its capacity; the ground matches at full resolution";
  }
  return std::string();
}

std::optional<double> eoDifferencePx(const eo_solution_t& rover, const Network& net,
                                     const std::vector<std::string>& stems, const Vec3& gimbal_m,
                                     int32_t* compared) {
  EoSet est, ref;
  for (const eo_entry_t& e : rover.images) {
    const auto it = std::find(stems.begin(), stems.end(), e.stem);
    if (it == stems.end()) continue;
    const NetImage& im = net.image(static_cast<int32_t>(it - stems.begin()));
    est.centers.emplace_back(e.center_m[0], e.center_m[1], e.center_m[2]);
    est.rotations.push_back(rotationFromOpk(e.omega_rad, e.phi_rad, e.kappa_rad));
    est.f_px.push_back(im.io.f_px);
    ref.centers.push_back(im.center_m);
    ref.rotations.push_back(im.m);
    ref.f_px.push_back(im.io.f_px);
  }
  if (compared != nullptr) *compared = static_cast<int32_t>(est.centers.size());
  if (est.centers.empty()) return std::nullopt;
  return alignedDifferencePx(est, ref, gimbal_m);
}

namespace {

// Step 1: tie points -- the rover's when they arrived complete, else the rover's matcher on the ground's
// images -- and the network with the rig constraints.
TieRun tiePointsStage(const Dataset& dataset, const std::function<const io::Panorama&()>& panorama,
                      const GroundPassOptions& options, const RoverInputs* rover, TieNetwork& network,
                      GroundPassResult& result, AdjustReport& report) {
  const std::string& out = options.out_dir;
  TieRun run;
  std::string why_not_rover = "not used (--no-rover-ties)";
  if (options.use_rover_ties) {
    why_not_rover =
        rover == nullptr ? "no rover input (a dataset folder)" : roverTiesIncomplete(dataset, *rover);
  }
  if (why_not_rover.empty()) {
    if (options.progress)
      cli::info("the rover's tie points (" + std::to_string(rover->ties.size()) + " observations)");
    run = roverTieRun(dataset, *rover, network, report.warnings);
    result.rover_ties_used = true;
  } else {
    if (rover != nullptr && options.use_rover_ties) {
      report.warnings.push_back("The rover's tie points are not used (" + why_not_rover +
                                "): the ground matched its own images instead.");
    }
    if (options.progress) cli::info("tie points on " + std::to_string(dataset.pairs.size()) + " pairs");
    run = runTiePoints(panorama(), options.progress, &network);
  }
  writeOrRecord(result, report, [&] { writeTiePoints(out, run); });
  report.seconds.emplace_back("tie_points", run.seconds);
  Network& net = *network.net;
  std::vector<std::string> notes;
  setRigConstraints(dataset, network.sol_of_index, net, notes);
  report.estimated = notes;
  result.pairs = static_cast<int32_t>(dataset.pairs.size());
  result.images = net.imageCount();
  result.points = net.pointCount();
  result.intra_observations = run.intra_observations;
  result.inter_observations = run.inter_observations;
  return run;
}

// The pairs that the hold-out check (ground/ties/HoldOutCheck.hpp) gave no evidence of improvement go back
// to their a-priori models, each said on the console and in report.json's warnings.
void keepAprioriWhere(const HoldOutResult& check, Network& net, bool progress,
                      std::vector<std::string>& warnings) {
  for (const PairVerdict& v : check.pairs) {
    const std::string line = "pair " + std::to_string(v.pair) + ": " + std::to_string(v.ties) +
                             " tie points, " + std::to_string(v.wrong_ties) + " wrong; " + v.reason;
    if (v.adjusted) {
      if (progress) cli::info(line + ": adjusted cameras kept");
      continue;
    }
    warnings.push_back("Pair " + std::to_string(v.pair) + " keeps its a-priori camera models: " + v.reason +
                       ".");
    cli::warn(line + ": the a-priori models are kept");
  }
  (void)keepAprioriWhereRejected(net, check);
}

// Step 2: the fast adjustment (rejection, figures), then the integrated reference from the a-priori EO;
// the report's precision, rig and truth figures of the integrated solution.
AdjustOutcome adjustStage(const Dataset& dataset, const GroundPassOptions& options, Network& net,
                          const NetworkTruth& truth, GroundPassResult& result, AdjustReport& report) {
  const Vec3 gimbal = net.rig.gimbal_m[0];
  if (options.progress) {
    cli::info("fast adjustment: " + std::to_string(net.imageCount()) + " images, " +
              std::to_string(net.pointCount()) + " points");
  }
  double t0 = cli::nowSeconds();
  const AdjustOutcome fast = adjustNetwork(net, FastAdjustOptions{});
  report.seconds.emplace_back("adjust_fast", cli::nowSeconds() - t0);
  if (!ok(fast.result.status)) {
    throw cli::InputError(dataset.root + "/panorama.json", "pairs",
                          std::string("the fast adjustment failed: ") + statusName(fast.result.status));
  }
  result.method1_fast_px = fast.after.dist;
  result.fast_sweeps = fast.result.sweeps_total;
  result.rejected_observations = fast.result.rejected_observations;
  const EoSet fast_eo = currentEo(net);
  if (truth.available) {
    result.truth_eo_fast_px =
        truthErrors(net, truth.centers.data(), truth.rotations.data(), nullptr, gimbal, true, kNominalRange_m)
            .eo_px;
  }
  std::vector<bool> rejected(static_cast<std::size_t>(net.observationCount()));
  for (int32_t k = 0; k < net.observationCount(); ++k) rejected[k] = net.observation(k).rejected;
  net.resetToApriori();
  for (int32_t k = 0; k < net.observationCount(); ++k) net.observation(k).rejected = rejected[k];
  const double t_check = cli::nowSeconds();
  result.holdout = holdOutCheck(net, FastAdjustOptions{});  // wrong ties rejected in net
  report.seconds.emplace_back("adjust_holdout_check", cli::nowSeconds() - t_check);
  result.rejected_observations += result.holdout.wrong_observations;
  int32_t failed = 0;
  (void)net.triangulateAll(failed);
  report.method1_before = precisionMethod1(net);
  report.method2_before = precisionMethod2(net);
  report.method3_before = precisionMethod3(net);
  if (options.progress) cli::info("integrated adjustment (Ceres sparse Schur)");
  t0 = cli::nowSeconds();
  IntegratedResult integrated;
  try {
    integrated = adjustCeres(net);
  } catch (const std::runtime_error& e) {
    throw cli::InputError(dataset.root + "/panorama.json", "pairs",
                          std::string("the integrated adjustment failed: ") + e.what());
  }
  report.seconds.emplace_back("adjust_integrated", cli::nowSeconds() - t0);
  if (!integrated.converged)
    report.warnings.push_back("The integrated adjustment did not report convergence.");
  if (!integrated.covariance_note.empty()) report.warnings.push_back(integrated.covariance_note);
  keepAprioriWhere(result.holdout, net, options.progress, report.warnings);
  report.solver = "ceres (integrated reference; outliers rejected by the fast adjustment first)";
  report.stop_rule = integrated.converged ? "converged" : "not_converged";
  report.iterations = integrated.iterations;
  report.rms_px = integrated.rms_px;
  report.sigma0 = integrated.sigma0;
  report.method1_after = precisionMethod1(net);
  report.method2_after = precisionMethod2(net);
  report.method3_after = precisionMethod3(net);
  report.tie_points = countTiePoints(net);
  report.constraints = {{"gimbal", true}, {"base", true}, {"fido", false}, {"datum_prior", true}};
  setRigFigures(report, net);  // of the integrated solution, whose models are written
  result.method1_before_px = report.method1_before.dist;
  result.method1_after_px = report.method1_after.dist;
  result.integrated_iterations = integrated.iterations;
  result.rms_px = integrated.rms_px;
  result.fast_vs_ground_px = alignedDifferencePx(fast_eo, currentEo(net), gimbal);
  if (truth.available) {
    const TruthErrors aligned = truthErrors(net, truth.centers.data(), truth.rotations.data(), nullptr,
                                            gimbal, true, kNominalRange_m);
    const TruthErrors raw = truthErrors(net, truth.centers.data(), truth.rotations.data(), nullptr, gimbal,
                                        false, kNominalRange_m);
    TruthFigures t;
    t.eo_px = aligned.eo_px;
    t.eo_px_raw = raw.eo_px;
    t.eo_px_before = result.truth_eo_before_px;
    report.truth = t;
    result.truth_eo_after_px = aligned.eo_px;
    report.warnings.push_back("truth.ground_m is not given: automatic tie points have no true positions.");
  }

  return fast;
}

// The rover's part of the products: rover_models/, rover_tiepoints.csv, its EO against the ground's, its
// status figures (the report's "rover" object) and warnings.
json roverFigures(const RoverInputs* rover, const Network& net, const std::vector<std::string>& stems,
                  const std::string& out, GroundPassResult& result, AdjustReport& report) {
  const Vec3 gimbal = net.rig.gimbal_m[0];
  json rover_json = json::object();
  if (rover != nullptr && rover->eo) {
    fs::create_directories(out + "/rover_models");
    for (const eo_entry_t& e : rover->eo->images) {
      CameraModel model;
      std::string why;
      const char* field = "";
      if (!ok(toCameraModel(e.model, model, field)) || e.stem.empty() ||
          e.stem.find('/') != std::string::npos || !isSafeRelativePath(e.stem, why)) {
        report.warnings.push_back("The rover's EO entry '" + e.stem + "' has no usable model; not written.");
        continue;
      }
      writeOrRecord(result, report,
                    [&] { io::writeCameraModelFile(out + "/rover_models/" + e.stem + ".cahvor", model); });
    }
    int32_t compared = 0;
    result.rover_vs_ground_px = eoDifferencePx(*rover->eo, net, stems, gimbal, &compared);
    rover_json["eo_vs_ground_px"] =
        result.rover_vs_ground_px ? json(*result.rover_vs_ground_px) : json(nullptr);
    rover_json["eo_images_compared"] = compared;
    rover_json["eo_is_final"] = static_cast<bool>(rover->eo->is_final);
    rover_json["sweeps"] = rover->eo->sweeps;
    rover_json["rms_px"] = rover->eo->rms_px;
    if (!rover->eo->is_final)
      report.warnings.push_back("The rover's final EO solution did not arrive; its last one is compared.");
  }
  if (rover != nullptr) {
    if (rover->status) {
      const rover_status_t& s = *rover->status;
      rover_json["heap_allocs_after_init"] = s.heap_allocs_after_init;
      rover_json["static_bytes"] = s.static_bytes;  // static and start-up reserve, against the 64 MiB budget
      const int32_t accepted = std::max(1, s.pairs_accepted);
      double total = 0.0;
      json stages = json::object();
      const char* names[] = {"decode", "features", "match", "dem", "adjust", "publish"};
      for (int k = 0; k < 6; ++k) {
        stages[names[k]] = s.stage_seconds[k] / accepted;
        total += s.stage_seconds[k];
      }
      rover_json["seconds_per_pair"] = total / accepted;
      rover_json["stage_seconds_per_pair"] = stages;
      rover_json["pairs_seen"] = s.pairs_seen;
      rover_json["pairs_accepted"] = s.pairs_accepted;
      rover_json["pairs_rejected"] = s.pairs_rejected;
      rover_json["pairs_binned"] = s.pairs_binned;  // frames above the rover's capacity, binned to fit it
      rover_json["sequence_gaps"] = s.sequence_gaps;
      if (!s.last_error.empty()) report.warnings.push_back("The rover reported: " + s.last_error);
    }
    if (!rover->ties.empty()) {
      writeOrRecord(result, report,
                    [&] { writeObservationsCsv(out + "/rover_tiepoints.csv", rover->ties, true); });
    }
    rover_json["tiepoint_messages"] = rover->tie_messages;
    rover_json["tiepoint_observations"] = rover->tie_observations;
    rover_json["coarse_dem_messages"] = rover->dem_messages;
    for (const std::string& w : rover->warnings) report.warnings.push_back(w);
    if (!rover->eo && !rover->status)
      report.warnings.push_back("Nothing arrived from the rover: no rover figures.");
  }
  return rover_json;
}

}  // namespace

GroundPassResult runGroundPass(const Dataset& dataset, const GroundPassOptions& options,
                               const StreamCounts* stream, const RoverInputs* rover,
                               const io::Panorama* loaded) {
  const std::string& out = options.out_dir;
  fs::create_directories(out);
  GroundPassResult result;
  AdjustReport report;
  for (const std::string& note : dataset.notes) report.warnings.push_back(note);

  // The images and their a-priori models, read once when a stage first needs them (the ground's matcher,
  // the products); the rover's ties and --no-products need neither.
  std::optional<io::Panorama> read;
  const auto panorama = [&]() -> const io::Panorama& {
    if (loaded != nullptr) return *loaded;
    if (!read) read = io::loadPanorama(dataset);
    return *read;
  };

  // 1. Tie points and the network.
  TieNetwork network;
  const TieRun run = tiePointsStage(dataset, panorama, options, rover, network, result, report);
  Network& net = *network.net;
  const std::vector<std::string>& stems = network.stem_of_image;

  // Truth (true models) when there is any.
  const std::string truth_root = truthRoot(dataset, options.truth_dir);
  NetworkTruth truth;
  if (!truth_root.empty()) {
    Dataset truth_dataset = dataset;
    truth_dataset.root = truth_root;
    NetworkSource source;
    source.stems = stems;
    truth = loadNetworkTruth(truth_dataset, source, false);
    if (!truth.available)
      report.warnings.push_back("truth: a true model is missing in " + truth_root + "/truth/models.");
  }
  if (truth.available) {
    result.truth_eo_before_px = truthErrors(net, truth.centers.data(), truth.rotations.data(), nullptr,
                                            net.rig.gimbal_m[0], true, kNominalRange_m)
                                    .eo_px;
  }

  // 2. The fast and the integrated adjustment.
  const AdjustOutcome fast = adjustStage(dataset, options, net, truth, result, report);

  // 3. Products: the adjusted models, eo.csv, the rover's part, then the products hook and report.json.
  const double t0 = cli::nowSeconds();
  std::vector<std::string> model_errors;
  writeAdjustedModels(out + "/models", net, network.apriori_of_image, stems, &model_errors);
  for (const std::string& e : model_errors) recordWriteError(result, report, e);
  writeOrRecord(result, report, [&] { writeEoCsv(out + "/eo.csv", net, stems); });
  const json rover_json = roverFigures(rover, net, stems, out, result, report);
  report.seconds.emplace_back("write_adjustment", cli::nowSeconds() - t0);
  if (options.products_hook) {
    ProductContext context{&panorama(),
                           out,
                           &net,
                           &stems,
                           &network.apriori_of_image,
                           &run.observations,
                           &report,
                           truth_root,
                           &result.write_errors};
    options.products_hook(context);
  } else {
    report.warnings.push_back(
        "DEM, orthoimage and previews were not made (no products hook: --no-products, or ground/products not "
        "linked).");
  }
  if (stream != nullptr) {
    for (const std::string& w : stream->warnings) report.warnings.push_back(w);
  }
  writeOrRecord(result, report,
                [&] { writeNodeReport(out, report, stream, rover, rover_json, fast, result); });
  result.seconds = report.seconds;
  result.warnings = report.warnings;
  return result;
}

namespace {

// report.json "adjustment_check": the hold-out check's figures per pair (HoldOutCheck.hpp).
json holdOutJson(const HoldOutResult& check) {
  json pairs = json::array();
  for (const PairVerdict& v : check.pairs) {
    pairs.push_back({{"pair", v.pair},
                     {"ties", v.ties},
                     {"wrong_ties", v.wrong_ties},
                     {"heldout_apriori_rms_px", v.apriori_rms_px},
                     {"heldout_adjusted_rms_px", v.adjusted_rms_px},
                     {"improvement_px2", v.improvement_px2},
                     {"standard_error_px2", v.standard_error_px2},
                     {"adjusted", v.adjusted},
                     {"reason", v.reason}});
  }
  return json{{"method", "k-fold cross-validation of the tie points (held-out residuals)"},
              {"folds", check.folds},
              {"wrong_observations", check.wrong_observations},
              {"pairs", pairs}};
}

// report.json: ground/adjust's report, then the node's keys added to it.
void writeNodeReport(const std::string& out, const AdjustReport& report, const StreamCounts* stream,
                     const RoverInputs* rover, const json& rover_json, const AdjustOutcome& fast,
                     const GroundPassResult& result) {
  writeReportJson(out + "/report.json", report);
  json j;
  {
    std::ifstream in(out + "/report.json");
    in >> j;
  }
  if (stream != nullptr) {
    j["stream"] = {{"pairs", stream->pairs},
                   {"gaps", stream->gaps},
                   {"duplicates", stream->duplicates},
                   {"reordered", stream->reordered},
                   {"rejected", stream->rejected},
                   {"end_of_panorama", stream->end_of_panorama},
                   {"pairs_planned", stream->pairs_planned}};
  }
  if (rover != nullptr) j["rover"] = rover_json;
  j["ground"] = {{"ties", result.rover_ties_used
                              ? "the rover's tie points (AREOMAP_TIEPOINTS)"
                              : "the rover's matcher (firmware_core/match) run on the ground's images"},
                 {"tie_source", result.rover_ties_used ? "rover" : "ground"},
                 {"reference", "integrated adjustment, Ceres sparse Schur"},
                 {"method1_fast_px", differences(fast.after)},
                 {"fast_sweeps", fast.result.sweeps_total},
                 {"fast_vs_integrated_px", *result.fast_vs_ground_px}};
  if (result.truth_eo_fast_px) j["truth"]["eo_px_fast"] = *result.truth_eo_fast_px;
  j["adjustment_check"] = holdOutJson(result.holdout);
  cli::writeFileAtomic(out + "/report.json", j.dump(2) + "\n");
}

}  // namespace

std::vector<ManifestEntry> buildManifest(const std::string& out_dir, const std::string& exclude_prefix) {
  std::vector<ManifestEntry> files;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(out_dir)) {
    if (!e.is_regular_file()) continue;
    const std::string rel = fs::relative(e.path(), out_dir).generic_string();
    if (!exclude_prefix.empty() && rel.rfind(exclude_prefix, 0) == 0) continue;
    if (rel == kRecordingName) continue;
    if (rel.find(".tmp-") != std::string::npos) continue;
    files.push_back(ManifestEntry{rel, static_cast<int64_t>(e.file_size()), sha256File(e.path().string())});
  }
  std::sort(files.begin(), files.end(),
            [](const ManifestEntry& a, const ManifestEntry& b) { return a.name < b.name; });
  return files;
}

product_t manifestMessage(const std::string& panorama, const std::string& out_dir,
                          const std::vector<ManifestEntry>& files, int64_t sequence) {
  product_t m;
  m.utime = static_cast<int64_t>(cli::nowSeconds() * 1e6);
  m.sequence = sequence;
  m.panorama = panorama;
  m.out_dir = out_dir;
  m.num_files = static_cast<int32_t>(files.size());
  for (const ManifestEntry& f : files) {
    m.names.push_back(f.name);
    m.bytes.push_back(f.bytes);
    m.sha256_hex.push_back(f.sha256_hex);
  }
  return m;
}

}  // namespace areomap::ground
