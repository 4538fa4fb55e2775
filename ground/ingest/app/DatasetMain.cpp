// areomap-dataset INPUT... --out DIR: frames as downloaded -> one dataset folder per rover position.
// DESIGN.md "Frames as downloaded"; the work is ground/ingest/Ingest.hpp.
#include <string>
#include <vector>

#include "ground/cli/Cli.hpp"
#include "ground/ingest/Ingest.hpp"

namespace {

constexpr const char* kUsage =
    "usage: areomap-dataset INPUT... --out DIR\n"
    "\n"
    "Turns frames as downloaded into datasets that every areomap tool reads. INPUT: files or folders\n"
    "(recursed), any mix of: Mars 2020 raw-image records as served or flattened (X.json or X-metadata.json,\n"
    "the image X.png/.jpg beside it), PDS3 products (.IMG with an attached label, .LBL with its data file;\n"
    "GEOMETRIC_CAMERA_MODEL or GEOMETRIC_CAMERA_MODEL_PARMS), VICAR products (PROPERTY "
    "GEOMETRIC_CAMERA_MODEL)\n"
    "and PDS4 labels (geom:CAHVORE_Model / CAHVOR / CAHV), the last two through GDAL.\n"
    "\n"
    "Pairing: left and right eyes of ONE exposure: the eye from the instrument (..._LEFT / _RIGHT), else "
    "the\n"
    "product id's eye letter; the exposure is the product id without it (M2020 and MSL: the 2nd letter,\n"
    "NLF_0395_0702014201_... / NRF_0395_0702014201_...; MER: the 24th, ...P0706L0M1 / ...P0706R0M1); the\n"
    "spacecraft clocks within 1 s and the same sol, site and drive. Two exposures are never paired.\n"
    "\n"
    "Output, one folder per rover position (mission, site, drive), named\n"
    "<mission>_sol<SSSS>_site<SSS>_drive<DDDD> (the position's first sol), e.g. "
    "m2020_sol0395_site017_drive1064:\n"
    "  DIR/<name>/panorama.json   pairs (id, sol, tier, left/right image, model and source = the input as\n"
    "                             given); no rig: the tools estimate it from the models\n"
    "  DIR/<name>/images/*.png    8-bit grey: colour by the BT.601 luma 0.299 R + 0.587 G + 0.114 B; data\n"
    "                             wider than 8 bits scaled by 255 / (2^k - 1), k the smallest of 8, 10, 12,\n"
    "                             14, 16 holding the image's largest value (12-bit data: / 4095 * 255); "
    "PDS3\n"
    "                             by the label's SAMPLE_BIT_MASK (or 2^SAMPLE_BITS - 1)\n"
    "  DIR/<name>/models/*.cahvor the model in the delivered image's pixels, in the SITE frame (+X north,\n"
    "                             +Y east, +Z down): X_site = R(attitude) X_rover + xyz (C rotated and\n"
    "                             shifted, A H V O rotated, R E unchanged)\n"
    "  DIR/index.json             datasets (name, folder, pairs with both sources) and skipped (every input\n"
    "                             left out with its reason)\n"
    "Pairs are in clock order; tier by the left camera axis's elevation in the rover frame, from the "
    "highest,\n"
    "a new tier where it drops by more than 5 degrees.\n"
    "\n"
    "Progress on stderr. Exit: 0 ok (inputs left out for a reason, such as an eye without its partner or a\n"
    "model in a frame that cannot be brought to the site frame, are listed in index.json), 2 usage error,\n"
    "1 a bad input (unreadable record or label, missing or corrupt image: named with its field on stderr;\n"
    "every other dataset is still written).\n";

}  // namespace

int main(int argc, char** argv) {
  return areomap::cli::runTool("areomap-dataset", argc, argv, kUsage, [](areomap::cli::Args& args) {
    const std::string out = args.required("--out");
    const std::size_t n = args.positionalCount();
    if (n == 0) throw areomap::cli::UsageError("at least one INPUT expected");
    std::vector<std::string> inputs;
    for (std::size_t i = 0; i < n; ++i) inputs.push_back(args.positional(i, "INPUT"));
    const areomap::ingest::IngestResult result = areomap::ingest::makeDatasets(inputs, out);
    areomap::cli::info(std::to_string(result.datasets.size()) + " datasets, " +
                       std::to_string(result.skipped.size()) + " inputs left out: " + out + "/index.json");
    return result.errors ? 1 : 0;
  });
}
