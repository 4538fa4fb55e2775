// The constraint sigmas of panorama.json in the adjusters' form (firmware_core/adjust/Network.hpp): a sigma
// the dataset gives is used as given (a looser one is honoured, its misfits may then exceed the bound); an
// absent one is held: it starts at kHeldRigSigma_m and the adjusters tighten it until its constraint holds
// to kRigMisfitBound_m.
#pragma once

#include <string>
#include <vector>

#include "firmware_core/adjust/Constraints.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "ground/dataset/Dataset.hpp"

namespace areomap {

// Sets rig.sigma_gimbal_m / sigma_base_m and rig.hold_gimbal / hold_base from the dataset; `notes` (when not
// null) receives heldSigmaNote() for each absent sigma.
void applyRigSigmas(const Rig& given, RigConstraints& rig, std::vector<std::string>* notes);

// "rig.sigma_gimbal_m: absent, Eq. 3 is held: ..." (field "rig.sigma_gimbal_m" or "rig.sigma_base_m").
std::string heldSigmaNote(const std::string& field);

// After an adjustment: one sentence per held sigma that the adjusters tightened (its final value and
// misfit), and in `warnings` one per held constraint that still misses the bound.
void heldSigmaOutcome(const RigConstraints& rig, const ConstraintMisfit& misfit,
                      std::vector<std::string>& notes, std::vector<std::string>& warnings);

}  // namespace areomap
