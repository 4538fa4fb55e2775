#include "ground/pass/GroundPass.hpp"

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
#include "ground/pass/PassProducts.hpp"
#include "ground/pass/PassReport.hpp"
#include "ground/ties/TieAdjust.hpp"
#include "ground/ties/TieRunner.hpp"
#include "msgs/adapters/MessageAdapters.hpp"

namespace areomap::ground {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

constexpr double kNominalRange_m = 5.0;  // pixel equivalent of EO differences (as in the adjust reports)

struct EoSet {
  std::vector<Vec3> centres;
  std::vector<Mat3> rotations;
  std::vector<double> f_px;
};

EoSet currentEo(const Network& net) {
  EoSet s;
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    s.centres.push_back(net.image(i).centre_m);
    s.rotations.push_back(net.image(i).m);
    s.f_px.push_back(net.image(i).io.f_px);
  }
  return s;
}

// RMS pixel equivalent of `est` against `ref` after the best-fit common rotation about gimbal_m.
double alignedDifferencePx(const EoSet& est, const EoSet& ref, const Vec3& gimbal_m) {
  const int32_t n = static_cast<int32_t>(est.centres.size());
  if (n == 0) return 0.0;
  const Mat3 r = commonRotation(est.rotations.data(), ref.rotations.data(), n);
  double sum = 0.0;
  for (int32_t i = 0; i < n; ++i) {
    Mat3 m;
    m.noalias() = est.rotations[i] * r.transpose();
    Vec3 c = gimbal_m;
    c.noalias() += r * (est.centres[i] - gimbal_m);
    const double px = eoPixelEquivalent(ref.f_px[i], c - ref.centres[i], rotationAngle(m, ref.rotations[i]),
                                        kNominalRange_m);
    sum += px * px;
  }
  return std::sqrt(sum / n);
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
    est.centres.emplace_back(e.center_m[0], e.center_m[1], e.center_m[2]);
    est.rotations.push_back(rotationFromOpk(e.omega_rad, e.phi_rad, e.kappa_rad));
    est.f_px.push_back(im.io.f_px);
    ref.centres.push_back(im.centre_m);
    ref.rotations.push_back(im.m);
    ref.f_px.push_back(im.io.f_px);
  }
  if (compared != nullptr) *compared = static_cast<int32_t>(est.centres.size());
  if (est.centres.empty()) return std::nullopt;
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
  const RigModelChoice rig = setRigConstraints(dataset, network.sol_of_index, net, notes);
  if (rig.fido) {
    cli::info(rig.sentence);
    dropGimbalModelNotes(report.warnings);
  }
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
        truthErrors(net, truth.centres.data(), truth.rotations.data(), nullptr, gimbal, true, kNominalRange_m)
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
  report.constraints = constraintsInUse(net.rig);
  setRigFigures(report, net);  // of the integrated solution, whose models are written
  result.method1_before_px = report.method1_before.dist;
  result.method1_after_px = report.method1_after.dist;
  result.integrated_iterations = integrated.iterations;
  result.rms_px = integrated.rms_px;
  result.fast_vs_ground_px = alignedDifferencePx(fast_eo, currentEo(net), gimbal);
  if (truth.available) {
    const TruthErrors aligned = truthErrors(net, truth.centres.data(), truth.rotations.data(), nullptr,
                                            gimbal, true, kNominalRange_m);
    const TruthErrors raw = truthErrors(net, truth.centres.data(), truth.rotations.data(), nullptr, gimbal,
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

}  // namespace

const CameraModel* SitePass::adjustedOf(const std::string& stem) const {
  const auto it = std::find(stems.begin(), stems.end(), stem);
  return it == stems.end() ? nullptr : &adjusted[static_cast<std::size_t>(it - stems.begin())];
}

const CameraModel* SitePass::aprioriOf(const std::string& stem) const {
  const auto it = std::find(stems.begin(), stems.end(), stem);
  return it == stems.end() ? nullptr : &apriori[static_cast<std::size_t>(it - stems.begin())];
}

namespace {

// Truth (true models) when there is any: the network's truth and its a-priori EO error.
NetworkTruth passTruth(const Dataset& dataset, const std::string& truth_root, const Network& net,
                       const std::vector<std::string>& stems, GroundPassResult& result,
                       AdjustReport& report) {
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
    result.truth_eo_before_px = truthErrors(net, truth.centres.data(), truth.rotations.data(), nullptr,
                                            net.rig.gimbal_m[0], true, kNominalRange_m)
                                    .eo_px;
  }
  return truth;
}

// Step 3: the adjusted models, eo.csv and the rover's part, written; the pass's solution kept as data.
json adjustmentProducts(const RoverInputs* rover, TieNetwork& network, const std::string& out,
                        SitePass& pass) {
  const double t0 = cli::nowSeconds();
  const Network& net = *network.net;
  const std::vector<std::string>& stems = network.stem_of_image;
  for (int32_t i = 0; i < net.imageCount(); ++i)
    pass.adjusted.push_back(adjustedModelOf(net, i, network.apriori_of_image[static_cast<std::size_t>(i)]));
  std::vector<std::string> model_errors;
  writeAdjustedModels(out + "/models", net, network.apriori_of_image, stems, &model_errors);
  for (const std::string& e : model_errors) recordWriteError(pass.summary, pass.report, e);
  writeOrRecord(pass.summary, pass.report, [&] { writeEoCsv(out + "/eo.csv", net, stems); });
  const json rover_json = roverFigures(rover, net, stems, out, pass.summary, pass.report);
  pass.report.seconds.emplace_back("write_adjustment", cli::nowSeconds() - t0);
  return rover_json;
}

// The DEM, ortho and previews (PassProducts.hpp), kept as data too.
void denseProducts(const std::string& truth_root, SitePass& pass) {
  ProductContext context{pass.panorama.get(), pass.out_dir,  &*pass.network,
                         &pass.stems,         &pass.apriori, &pass.ties,
                         &pass.report,        truth_root,    &pass.summary.write_errors};
  products::ProductsResult made = makePassProducts(context);
  pass.dem = std::move(made.dem);
  pass.dem_sigma = std::move(made.dem_sigma);
  pass.ortho = std::move(made.ortho);
}

}  // namespace

SitePass runGroundPass(const Dataset& dataset, const GroundPassOptions& options, const StreamCounts* stream,
                       const RoverInputs* rover, std::shared_ptr<const io::Panorama> loaded) {
  const std::string& out = options.out_dir;
  fs::create_directories(out);
  SitePass pass;
  pass.out_dir = out;
  pass.dataset = dataset;
  pass.panorama = std::move(loaded);
  GroundPassResult& result = pass.summary;
  AdjustReport& report = pass.report;
  for (const std::string& note : dataset.notes) report.warnings.push_back(note);

  // The images and their a-priori models, read once when a stage first needs them (the ground's matcher,
  // the products); the rover's ties and --no-products need neither.
  const auto panorama = [&]() -> const io::Panorama& {
    if (!pass.panorama) pass.panorama = std::make_shared<const io::Panorama>(io::loadPanorama(dataset));
    return *pass.panorama;
  };

  // 1. Tie points and the network.
  TieNetwork network;
  TieRun run = tiePointsStage(dataset, panorama, options, rover, network, result, report);
  Network& net = *network.net;
  const std::string truth_root = truthRoot(dataset, options.truth_dir);
  const NetworkTruth truth = passTruth(dataset, truth_root, net, network.stem_of_image, result, report);

  // 2. The fast and the integrated adjustment.
  const AdjustOutcome fast = adjustStage(dataset, options, net, truth, result, report);

  // 3. Products: the adjusted models, eo.csv, the rover's part, then the DEM and ortho, and report.json.
  const json rover_json = adjustmentProducts(rover, network, out, pass);
  pass.network = std::move(network.net);
  pass.stems = std::move(network.stem_of_image);
  pass.apriori = std::move(network.apriori_of_image);
  pass.ties = std::move(run.observations);
  if (options.products) {
    panorama();
    denseProducts(truth_root, pass);
  } else {
    report.warnings.push_back("DEM, orthoimage and previews were not made (--no-products).");
  }
  if (stream != nullptr) {
    for (const std::string& w : stream->warnings) report.warnings.push_back(w);
  }
  writeOrRecord(result, report, [&] {
    const json j = passReportJson(report, stream, rover, rover_json, fast, result);
    cli::writeFileAtomic(out + "/report.json", j.dump(2) + "\n");
  });
  result.seconds = report.seconds;
  result.warnings = report.warnings;
  return pass;
}

}  // namespace areomap::ground
