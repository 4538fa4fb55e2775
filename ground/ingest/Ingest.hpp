// areomap-dataset's work: frames as downloaded -> one dataset folder per rover position (DESIGN.md
// "Frames as downloaded").
//
//   DIR/<name>/panorama.json   name, image_size (when every image has one size), site, drive, mission and
//                              pairs: id, sol, tier, left and right {image, model, source, product_id};
//                              no rig (the readers estimate it from the a-priori models)
//   DIR/<name>/images/<stem>.png   8-bit grey (io::toGrey8: colour by BT.601 luma, wider data by a fixed
//                                  scale per bit depth; PDS3 by its label's bit mask, io::loadImage8)
//   DIR/<name>/models/<stem>.cahvor   the model in the delivered image's pixels and in the site's frame
//                                     (SiteFrame.hpp)
//   DIR/index.json   datasets [{name, folder, pairs [{id, left {product_id, source}, right {...}}]}] and
//                    skipped [{input, reason}]: every input left out and why
//
// A pair's left and right eyes are one exposure (Pairing.hpp). Pairs are grouped by rover position
// (mission, site, drive); name "<mission>_sol<SSSS>_site<SSS>_drive<DDDD>" (mission lower case, the
// position's first sol), e.g. m2020_sol0395_site017_drive1064. Within a dataset pairs are in clock order;
// sol is the pair's own (0 when not given); tier by the elevation of the left camera's axis in the rover
// frame (the mast elevation): sorted from the highest, a new tier where the next pair's elevation lies
// more than kTierGapDeg below the one before.
#pragma once

#include <string>
#include <vector>

#include "ground/ingest/FrameScan.hpp"

namespace areomap::ingest {

// Navcam tiers of a panorama are one vertical field of view (~45 deg MER/MSL, ~73 deg M2020) apart minus
// their overlap; the pointing of one tier scatters by a degree or two with the rover's tilt.
constexpr double kTierGapDeg = 5.0;

struct IngestedEye {
  std::string product_id;
  std::string source;
};

struct IngestedPair {
  int id = 0;
  IngestedEye left;
  IngestedEye right;
};

struct IngestedDataset {
  std::string name;
  std::string folder;  // relative to the output folder (the name)
  std::vector<IngestedPair> pairs;
};

struct IngestResult {
  std::vector<IngestedDataset> datasets;
  std::vector<Skipped> skipped;
  bool errors = false;  // some input was bad (a Skipped with error), or a dataset could not be written
};

// Reads `inputs`, pairs, groups and writes every dataset and DIR/index.json (see above). Bad inputs are
// reported on stderr (file and field) and in `skipped`; every other dataset is still written.
IngestResult makeDatasets(const std::vector<std::string>& inputs, const std::string& out_dir);

std::string datasetName(io::Mission mission, int sol, int site, int drive);

}  // namespace areomap::ingest
