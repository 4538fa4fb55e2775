// Whether the adjustment made each pair's cameras better than its a-priori (calibrated, pointing-derived)
// models, on evidence the adjustment did not fit: K-fold cross-validation over the tie points.
//
// Why: with a pair alone at a position (or a pair whose ties reach no other pair) the relative orientation
// of its two cameras is determined by its own ties only (the stereo base fixes the centres, not the
// rotation between the eyes). Real calibrated models are good to a fraction of a pixel; a few ties bunched
// in one part of the image, or a few wrong ones, then move the cameras away from a better a-priori
// solution, and the ties' own residuals after the adjustment cannot show it (the adjustment fitted them).
// A tie left out of the adjustment can: its residual through the cameras adjusted without it is a fair
// prediction of how those cameras do on any new match.
//
// How (every threshold from the data, none fitted to a scene):
//   1. the usable points (>= 2 active observations) are dealt into kFolds folds in their list order (the
//      matcher's gridded order, so every fold spans the image). For each fold the network is adjusted
//      from the a-priori EO (firmware_core/adjust FastAdjuster, as the pass does) without the fold's
//      observations, and each held-out point is triangulated from its observations through those cameras
//      (least-squares reprojection): its residuals are the held-out residuals. The a-priori models' residuals
//      come from the same triangulation through the a-priori cameras (they never saw a tie);
//   2. wrong ties: a point whose held-out RMS residual exceeds kOutlierSigmas robust sigmas (1.4826 x the
//      median of all points' held-out RMS residuals) under BOTH the a-priori and the cross-validated cameras
//      is wrong whatever the cameras are: its observations are rejected, and step 1 runs again without them;
//   3. per pair, over its observations of the remaining points: the mean paired difference of the squared
//      residuals (a-priori minus cross-validated) and its standard error. The pair's adjusted cameras are
//      kept only when that mean exceeds kSignificance standard errors (the improvement is real, not noise);
//      otherwise, or with fewer than minTies() good ties (too few for the folds to fit the pair at all),
//      the pair keeps its a-priori models.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "firmware_core/adjust/FastAdjustOptions.hpp"
#include "firmware_core/adjust/Network.hpp"

namespace areomap {

struct HoldOutParams {
  // Five folds: each adjustment keeps 80 % of the ties (close to the whole network's geometry), and five
  // adjustments stay cheap next to the integrated one.
  int32_t folds = 5;
  // Wrong ties: beyond 4 robust sigmas under both camera sets (P ~ 6e-5 for a normal residual each).
  double outlier_sigmas = 4.0;
  // The one-sided test of the improvement: 2 standard errors (~2.3 % false acceptance of noise).
  double significance = 2.0;
};

// The fewest good ties a pair needs for a decision: each fold's training share of them must determine the
// pair's relative orientation (the right camera's rotation about the left, 3 unknowns, and the base
// direction within its held length, 2) with each unknown over-determined twice, and each fold must hold
// out at least two of them.
int32_t minTies(const HoldOutParams& params);

struct PairVerdict {
  int32_t pair = -1;
  int32_t ties = 0;              // points observed in the pair (before step 2)
  int32_t wrong_ties = 0;        // of those, rejected in step 2
  double apriori_rms_px = 0.0;   // held-out RMS residual of its observations, a-priori cameras
  double adjusted_rms_px = 0.0;  // ... cameras adjusted without them (cross-validated)
  double improvement_px2 = 0.0;  // mean paired difference of squared residuals (a-priori - adjusted)
  double standard_error_px2 = 0.0;
  bool adjusted = false;  // keeps its adjusted cameras; false: its a-priori models
  std::string reason;     // why (a sentence)
};

struct HoldOutResult {
  bool ran = false;
  int32_t folds = 0;
  int32_t wrong_observations = 0;  // rejected in step 2
  std::vector<PairVerdict> pairs;
};

// Runs the check on a copy of `net` (its rejection flags as the pass's robust adjustment left them; its EO
// as it is) and marks the wrong ties' observations rejected in `net`. `options`: the adjustment the pass
// uses (its robust rejection applies within each fold).
HoldOutResult holdOutCheck(Network& net, const FastAdjustOptions& options, const HoldOutParams& params = {});

// Puts every pair that keeps its a-priori models back to its a-priori EO (the others as they are) and
// triangulates every point again; returns how many pairs went back.
int32_t keepAprioriWhereRejected(Network& net, const HoldOutResult& check);

}  // namespace areomap
