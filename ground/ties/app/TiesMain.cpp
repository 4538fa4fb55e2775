// areomap-ties DATASET --out DIR [--adjust]: automatic tie points (paper §3.4) on a dataset folder.
#include <cstdio>
#include <string>

#include "ground/cli/Cli.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/ties/TieCheck.hpp"
#include "ground/ties/TieRunner.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include <filesystem>

namespace {

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
    "  --adjust    then run the fast adjustment on these ties (not available yet in this build)\n"
    "\n"
    "Exit: 0 ok, 2 usage error, 1 bad input (the message names the file and the field).\n";

}  // namespace

int main(int argc, char** argv) {
  return areomap::cli::runTool("areomap-ties", argc, argv, kUsage, [](areomap::cli::Args& args) {
    const std::string out = args.required("--out");
    const bool adjust = args.flag("--adjust");
    const std::string dataset_dir = args.positional(0, "DATASET");
    if (adjust) throw areomap::cli::UsageError("--adjust: the fast adjustment is not wired into areomap-ties yet");
    const areomap::Dataset dataset = areomap::readDataset(dataset_dir);
    const areomap::TieRun run = areomap::runTiePoints(dataset, true);
    areomap::writeTiePoints(out, run);
    areomap::writeOverlays(out, dataset, run);
    if (std::filesystem::exists(dataset.root + "/" + areomap::kTruthDemFile) &&
        std::filesystem::exists(dataset.root + "/" + areomap::kTruthModelsFolder)) {
      const areomap::TieCheck c = areomap::checkTiesAgainstTruth(dataset, run);
      std::printf("truth: %.2f %% of %d observations within 1 px (inter %.2f %% of %d), rms %.3f px; %d adjacent "
                  "pairs, weakest link %s\n",
                  100.0 * c.within_1px / std::max(1, c.checked), c.checked,
                  100.0 * c.inter_within_1px / std::max(1, c.inter_checked), c.inter_checked, c.rms_px,
                  c.adjacent_pairs, c.worst_link.c_str());
    }
    std::printf("tie points: %zu points, %d intra and %d inter observations, %.1f s; %s/tiepoints.csv\n",
                run.points_m.size(), run.intra_observations, run.inter_observations, run.seconds, out.c_str());
    return 0;
  });
}
