// Checks automatic tie points against the truth of a synthetic dataset (areomap-sim): the surface point a
// tie point claims is where the truth ray of its first observation meets truth/dem.tif; every further
// observation is compared with that point's projection by the image's truth model. Pairs are adjacent when
// they see common truth check points (truth/observations.csv); their link is the number of tie points
// observed in both.
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "ground/dataset/Dataset.hpp"
#include "ground/ties/TieRunner.hpp"

namespace areomap {

struct TieCheck {
  int checked = 0;  // observations compared (all but each point's first)
  int within_1px = 0;
  int inter_checked = 0;
  int inter_within_1px = 0;
  int no_surface = 0;  // points whose first ray does not meet the truth DEM (not counted)
  double rms_px = 0.0;
  // Mean signed error (measured - truth projection, px) of the intra-stereo observations within 1 px: a
  // matcher's systematic offset (a disparity bias moves every pair's relative orientation alike).
  double intra_mean_dx_px = 0.0;
  double intra_mean_dy_px = 0.0;
  // The same for the inter-stereo observations within 1 px, by the camera of their pair (0 left, 1 right):
  // a difference between the two is a disparity bias of the inter-stereo matches, which moves every
  // pair's convergence alike (a DEM raised or lowered in proportion to range).
  double inter_mean_dx_px[2] = {0.0, 0.0};
  double inter_mean_dy_px[2] = {0.0, 0.0};
  int inter_within_1px_by_side[2] = {0, 0};  // the observations those means are over
  // The intra-stereo mean error in x by the point's range from the first camera (bands of kRangeBands_m):
  // an error that grows or changes sign with range (a parallax scale error) is absorbed by the pairs'
  // vergence even where the overall mean is zero.
  static constexpr int kRangeBands = 5;
  static constexpr double kRangeBands_m[kRangeBands + 1] = {0.0, 3.0, 5.0, 10.0, 20.0, 1e9};
  double intra_mean_dx_by_range_px[kRangeBands] = {};
  int intra_by_range[kRangeBands] = {};
  std::map<std::pair<int, int>, int> links;  // adjacent pair indices -> tie points shared
  int adjacent_pairs = 0;
  int min_link = 0;
  std::string worst_link;  // "a-b: n"
};

TieCheck checkTiesAgainstTruth(const Dataset& dataset, const TieRun& run);

}  // namespace areomap
