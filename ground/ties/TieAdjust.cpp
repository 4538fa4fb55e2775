#include "ground/ties/TieAdjust.hpp"

#include "ground/dataset/RigEstimate.hpp"

namespace areomap {

void setRigConstraints(const Dataset& dataset, const std::vector<int>& sol_of_index, Network& net,
                       std::vector<std::string>& notes) {
  const RigEstimate rig = estimateRig(dataset.rig, sol_of_index, net, false);
  notes.insert(notes.end(), rig.estimated.begin(), rig.estimated.end());
  notes.insert(notes.end(), rig.warnings.begin(), rig.warnings.end());
  bool has_right = false;
  for (int32_t p = 0; p < net.pairCount(); ++p) has_right = has_right || net.pair(p).right >= 0;
  net.rig.use_base = has_right;
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
