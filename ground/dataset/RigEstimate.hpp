// The rig constants of a panorama (paper Eq. 3 and Eq. 4) in the adjusters' form: the values panorama.json
// gives are kept, the missing ones are estimated from the network's a-priori cameras. The one estimator of
// the ground: the ground pass, areomap-adjust, areomap-ties and areomap-pack all call it.
//
//  - Gimbal centre per sol and camera offsets (Eq. 3, C_i = XG_sol + M_i^T c_side): linear least squares
//    over the missing unknowns (given ones are constants), relative to the mean camera centre, minimum
//    norm (a panorama that only pans leaves the vertical offset and the gimbal height in trade-off, and the
//    minimum-norm choice must not depend on where the frame's origin lies).
//  - Stereo base (Eq. 4): the mean of M_L (C_R - C_L) over the pairs.
//  - FIDO (on request): a virtual spin centre per tier (sphere fit of the tier's camera centres), the
//    camera-to-centre distance per side and the left-right distance: the rover's fit,
//    firmware_core/adjust/RigShape.hpp fitFidoRig, which also holds the rule that asks for it.
//  - The sigmas: RigSigmas.hpp.
#pragma once

#include <string>
#include <vector>

#include "firmware_core/adjust/Network.hpp"
#include "ground/dataset/Dataset.hpp"

namespace areomap {

struct RigEstimate {
  std::vector<std::string> estimated;  // sentences: which rig values were estimated and how
  std::vector<std::string> warnings;   // a rank-deficient fit
  // The RMS (m) by which the fitted gimbal centres and camera offsets miss the a-priori camera centres; 0
  // when the dataset gives them all.
  double fit_rms_m = 0.0;
};

// Fills net.rig's values and sigmas (not its use_* switches). `sol_of_index`: the dataset sol number of
// each network sol index (net.image(i).sol indexes it).
RigEstimate estimateRig(const Rig& given, const std::vector<int>& sol_of_index, Network& net, bool fido);

}  // namespace areomap
