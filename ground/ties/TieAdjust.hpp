// The fast constrained adjustment (firmware_core/adjust FastAdjuster) of the automatic tie points: the
// network built pair by pair by NetworkBuilder, the rig constraints from panorama.json or, where missing,
// estimated from the a-priori models (ground/dataset/RigEstimate.hpp).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "firmware_core/adjust/FastAdjuster.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/adjust/Precision.hpp"
#include "ground/dataset/Dataset.hpp"

namespace areomap {

// Fills net.rig by estimateRig (sols of the network images must index dataset.rig.gimbal_m keys in order,
// as runTiePoints assigns them) and holds the stereo base where the network has a right image. `notes`
// receives what was estimated and the fit's warnings.
void setRigConstraints(const Dataset& dataset, const std::vector<int>& sol_of_index, Network& net,
                       std::vector<std::string>& notes);

// The paper's method 1 (back-projection residuals, firmware_core/adjust/Precision.hpp) before and after.
struct AdjustOutcome {
  ImageDifferences before;
  ImageDifferences after;
  double rms_before_px = 0.0;  // RMS per coordinate (FastAdjuster::evaluateCost)
  FastAdjustResult result;
};

// Triangulates every point with the a-priori cameras, measures, adjusts, measures again.
AdjustOutcome adjustNetwork(Network& net, const FastAdjustOptions& options);

}  // namespace areomap
