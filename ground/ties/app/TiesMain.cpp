// areomap-ties DATASET --out DIR [--adjust]: automatic tie points (paper §3.4) on a dataset folder.
#include <cstdio>
#include <string>

#include "ground/cli/Cli.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/RigSigmas.hpp"
#include "ground/ties/TieCheck.hpp"
#include "ground/ties/TieRunner.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "firmware_core/camera/CameraConversion.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/ties/TieAdjust.hpp"

namespace {

using json = nlohmann::json;

constexpr const char* kUsage =
    "usage: areomap-ties DATASET --out DIR [--adjust]\n"
    "\n"
    "Finds tie points automatically with the rover's pipeline (firmware_core/match): Förstner interest\n"
    "points, NCC matching along the a-priori epipolar curve with left-right and parallax-curve checks and\n"
    "gridding (intra-stereo), a coarse DEM per pair, and inter-stereo ties predicted through it into every\n"
    "earlier pair. Pairs are processed in panorama.json order, as they would arrive on the rover.\n"
    "\n"
    "Writes DIR/tiepoints.csv (point,image,sample_px,line_px,kind; kind intra or inter; image = the image\n"
    "file's stem) and DIR/overlays/<stem>.png (blue crosses intra-stereo, red inter-stereo). On a synthetic\n"
    "dataset (truth/dem.tif and truth/models present) it also prints how many observations lie within 1 px\n"
    "of the truth projection of the surface point they claim, and the weakest link between adjacent pairs.\n"
    "\n"
    "  --out DIR   output folder (created)\n"
    "  --adjust    then run the fast constrained adjustment (12x12 per pair, 3x3 per point) on these ties "
    "and\n"
    "              write DIR/models/<stem>.cahvor (adjusted) and DIR/report.json (method1_px before/after,\n"
    "              rms_px, sigma0, iterations, tie_points, seconds, warnings); rig values missing from\n"
    "              panorama.json are estimated from the a-priori models (named in warnings)\n"
    "\n"
    "Exit: 0 ok, 2 usage error, 1 bad input (the message names the file and the field).\n";

json method1(const areomap::ImageDifferences& d) {
  return json{{"x", d.x}, {"y", d.y}, {"dist", d.dist}};
}

// The fast adjustment of the ties: DIR/models/<stem>.cahvor (adjusted) and DIR/report.json (method 1
// before/after, rms_px, sigma0, iterations, tie point counts, timings, warnings).
void writeAdjustment(const std::string& out, const areomap::Dataset& dataset, const areomap::TieRun& run,
                     areomap::TieNetwork& network) {
  std::vector<std::string> notes;
  const areomap::RigModelChoice rig =
      areomap::setRigConstraints(dataset, network.sol_of_index, *network.net, notes);
  if (rig.fido) areomap::cli::info(rig.sentence);
  areomap::cli::info("adjusting " + std::to_string(network.net->imageCount()) + " images, " +
                     std::to_string(network.net->pointCount()) + " points");
  const double start = areomap::cli::nowSeconds();
  const areomap::AdjustOutcome o = areomap::adjustNetwork(*network.net, areomap::FastAdjustOptions{});
  const double seconds = areomap::cli::nowSeconds() - start;
  if (!areomap::ok(o.result.status)) {
    throw areomap::cli::InputError(
        dataset.root + "/panorama.json", "pairs",
        std::string("the adjustment failed: ") + areomap::statusName(o.result.status));
  }
  std::filesystem::create_directories(out + "/models");
  for (int32_t i = 0; i < network.net->imageCount(); ++i) {
    const areomap::NetImage& im = network.net->image(i);
    const areomap::CameraModel adjusted =
        areomap::adjustedModel(network.apriori_of_image[i], im.m_apriori, im.m, im.centre_m);
    areomap::io::writeCameraModelFile(out + "/models/" + network.stem_of_image[i] + ".cahvor", adjusted);
  }
  json report;
  report["method1_px"] = {{"before", method1(o.before)}, {"after", method1(o.after)}};
  report["rms_px"] = o.result.rms_px;
  report["sigma0"] = o.result.sigma0;
  report["iterations"] = o.result.sweeps_total;
  report["tie_points"] = {{"intra", run.intra_observations},
                          {"inter", run.inter_observations},
                          {"rejected", o.result.rejected_observations}};
  report["seconds"] = {{"ties", run.seconds}, {"adjust", seconds}};
  report["constraints"] = areomap::constraintsInUse(network.net->rig);
  areomap::heldSigmaOutcome(network.net->rig, o.result.max_misfit, notes, notes);
  report["warnings"] = notes;
  std::ofstream(out + "/report.json") << report.dump(2) << "\n";
  std::printf(
      "adjustment: method 1 mean distance %.3f px before, %.3f px after (rms per coordinate %.3f px, sigma0 "
      "%.3f, %d sweeps); "
      "%s/report.json\n",
      o.before.dist, o.after.dist, o.result.rms_px, o.result.sigma0, o.result.sweeps_total, out.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  return areomap::cli::runTool("areomap-ties", argc, argv, kUsage, [](areomap::cli::Args& args) {
    const std::string out = args.required("--out");
    const bool adjust = args.flag("--adjust");
    const std::string dataset_dir = args.positional(0, "DATASET");
    const areomap::io::Panorama panorama = areomap::io::loadPanorama(areomap::readDataset(dataset_dir));
    const areomap::Dataset& dataset = panorama.dataset;
    areomap::TieNetwork network;
    const areomap::TieRun run = areomap::runTiePoints(panorama, true, adjust ? &network : nullptr);
    areomap::writeTiePoints(out, run);
    areomap::writeOverlays(out, panorama, run);
    if (std::filesystem::exists(dataset.root + "/" + areomap::kTruthDemFile) &&
        std::filesystem::exists(dataset.root + "/" + areomap::kTruthModelsFolder)) {
      const areomap::TieCheck c = areomap::checkTiesAgainstTruth(dataset, run);
      std::printf(
          "truth: %.2f %% of %d observations within 1 px (inter %.2f %% of %d), rms %.3f px; %d adjacent "
          "pairs, weakest link %s\n",
          100.0 * c.within_1px / std::max(1, c.checked), c.checked,
          100.0 * c.inter_within_1px / std::max(1, c.inter_checked), c.inter_checked, c.rms_px,
          c.adjacent_pairs, c.worst_link.c_str());
      std::printf(
          "truth: intra-stereo observations within 1 px are off by %+.4f px in x and %+.4f px in y on "
          "average (measured - truth)\n",
          c.intra_mean_dx_px, c.intra_mean_dy_px);
      std::printf("truth: intra-stereo mean error in x by range:");
      for (int b = 0; b < areomap::TieCheck::kRangeBands; ++b) {
        const double lo = areomap::TieCheck::kRangeBands_m[b], hi = areomap::TieCheck::kRangeBands_m[b + 1];
        if (hi < 1e8) {
          std::printf(" %g-%g m %+.4f px (%d)", lo, hi, c.intra_mean_dx_by_range_px[b], c.intra_by_range[b]);
        } else {
          std::printf(" beyond %g m %+.4f px (%d)", lo, c.intra_mean_dx_by_range_px[b], c.intra_by_range[b]);
        }
      }
      std::printf("\n");
      std::printf(
          "truth: inter-stereo observations within 1 px are off by %+.4f / %+.4f px in x and %+.4f / %+.4f "
          "px in y "
          "in left / right images\n",
          c.inter_mean_dx_px[0], c.inter_mean_dx_px[1], c.inter_mean_dy_px[0], c.inter_mean_dy_px[1]);
    }
    if (adjust) writeAdjustment(out, dataset, run, network);
    std::printf("tie points: %zu points, %d intra and %d inter observations, %.1f s; %s/tiepoints.csv\n",
                run.points_m.size(), run.intra_observations, run.inter_observations, run.seconds,
                out.c_str());
    return 0;
  });
}
