// The fast constrained adjustment (firmware_core/adjust FastAdjuster) of the automatic tie points: the
// network built pair by pair by NetworkBuilder, the rig constraints from panorama.json or, where missing,
// estimated from the a-priori models (ground/dataset/RigEstimate.hpp).
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "firmware_core/adjust/FastAdjuster.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/adjust/Precision.hpp"
#include "firmware_core/adjust/RigShape.hpp"
#include "ground/dataset/Dataset.hpp"

namespace areomap {

// The rig model setRigConstraints chose by firmware_core/adjust/RigShape.hpp's rule.
struct RigModelChoice {
  bool fido = false;  // the cameras do not turn about one point: the FIDO model instead of Eq. 3
  RigShape shape;
  std::string sentence;  // the choice and the fit's RMS against the one-point limit (also in `notes`)
};

// Fills net.rig by estimateRig (sols of the network images must index dataset.rig.gimbal_m keys in order,
// as runTiePoints assigns them) and holds the stereo base where the network has a right image; when the
// a-priori cameras do not turn about one point (checkRigShape), switches to the FIDO model (useFidoModel:
// Eq. 3 with the mast's tilt arm and the base; the spin-centre distances where the tilts do not fix the
// arm). `notes` receives what was
// estimated, the fit's warnings and the choice.
RigModelChoice setRigConstraints(const Dataset& dataset, const std::vector<int>& sol_of_index, Network& net,
                                 std::vector<std::string>& notes);

// Drops from `notes` the dataset's notes on the gimbal model's values (rig.gimbal_m.<sol>, the camera
// offsets, rig.sigma_gimbal_m held): after a switch to the FIDO model they describe values that are not
// used (the tilt arm's own are fitted and said by estimateRig).
void dropGimbalModelNotes(std::vector<std::string>& notes);

// report.json's "constraints" of a network: which rig constraints its rig uses.
std::map<std::string, bool> constraintsInUse(const RigConstraints& rig);

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
