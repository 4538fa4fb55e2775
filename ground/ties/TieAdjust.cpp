#include "ground/ties/TieAdjust.hpp"

#include <algorithm>
#include <sstream>

#include "ground/dataset/RigEstimate.hpp"

namespace areomap {

RigModelChoice setRigConstraints(const Dataset& dataset, const std::vector<int>& sol_of_index, Network& net,
                                 std::vector<std::string>& notes) {
  RigModelChoice choice;
  choice.shape = checkRigShape(net);
  choice.fido = !choice.shape.one_point;
  const RigEstimate rig = estimateRig(dataset.rig, sol_of_index, net, choice.fido);
  notes.insert(notes.end(), rig.estimated.begin(), rig.estimated.end());
  notes.insert(notes.end(), rig.warnings.begin(), rig.warnings.end());
  bool has_right = false;
  for (int32_t p = 0; p < net.pairCount(); ++p) has_right = has_right || net.pair(p).right >= 0;
  net.rig.use_base = has_right;
  std::ostringstream s;
  s.precision(3);
  s << "Eq. 3 fitted to the a-priori cameras misses them by " << choice.shape.fit_rms_m * 1000.0
    << " mm RMS; a rig that turns about one point misses by at most " << choice.shape.threshold_m * 1000.0
    << " mm (the bound Eq. 3 must meet plus the larger camera offset, " << choice.shape.lever_m
    << " m, times the a-priori pointing sigma, " << net.rig.sigma_datum_rad << " rad): ";
  if (choice.fido) {
    useFidoModel(net);
    s << "the mast does not turn the cameras about one point, so the FIDO model is used ("
      << (net.rig.use_tilt_arm ? "Eq. 3 with the mast's tilt arm, held; the stereo base)."
                               : "a virtual spin centre per tier, camera-to-centre and left-right distances, "
                                 "the stereo base; Eq. 3 off).");
  } else {
    s << "the gimbal model (Eq. 3) is used.";
  }
  choice.sentence = s.str();
  notes.push_back(choice.sentence);
  return choice;
}

void dropGimbalModelNotes(std::vector<std::string>& notes) {
  const auto about_gimbal = [](const std::string& n) {
    for (const char* prefix :
         {"rig.gimbal_m.", "rig.left_offset_m:", "rig.right_offset_m:", "rig.sigma_gimbal_m:"})
      if (n.rfind(prefix, 0) == 0) return true;
    return false;
  };
  notes.erase(std::remove_if(notes.begin(), notes.end(), about_gimbal), notes.end());
}

std::map<std::string, bool> constraintsInUse(const RigConstraints& rig) {
  return {{"gimbal", rig.use_gimbal && !rig.use_tilt_arm},
          {"base", rig.use_base},
          {"fido", rig.use_spin_centre || rig.use_tilt_arm},
          {"datum_prior", rig.use_datum_prior}};
}

AdjustOutcome adjustNetwork(Network& net, const FastAdjustOptions& options) {
  AdjustOutcome out;
  int32_t failed = 0;
  (void)net.triangulateAll(failed);
  out.before = precisionMethod1(net);
  auto adjuster = std::make_unique<FastAdjuster>();
  (void)adjuster->evaluateCost(net, &out.rms_before_px);
  (void)adjuster->adjust(net, options, out.result);
  out.after = precisionMethod1(net);
  return out;
}

}  // namespace areomap
