#include "ground/dataset/RigSigmas.hpp"

#include <sstream>

namespace areomap {

namespace {

const char* equationOf(const std::string& field) {
  return field == "rig.sigma_gimbal_m" ? "Eq. 3" : "Eq. 4";
}

std::string millimetres(double metres) {
  std::ostringstream s;
  s.precision(3);
  s << metres * 1e3 << " mm";
  return s.str();
}

// `floor_m`: the least misfit the rig values allow (misfitFloor), `inconsistency_m` their disagreement.
void outcome(const char* field, bool held, double sigma_m, double misfit_m, double floor_m,
             double inconsistency_m, std::vector<std::string>& notes, std::vector<std::string>& warnings) {
  if (!held) return;
  const std::string eq = equationOf(field);
  if (sigma_m < kHeldRigSigma_m) {
    std::ostringstream s;
    s << field << ": tightened to " << sigma_m << " m by the adjustment so that " << eq
      << " holds (largest misfit " << millimetres(misfit_m) << ").";
    notes.push_back(s.str());
  }
  if (misfit_m > kRigMisfitBound_m) {
    const std::string why =
        floor_m > 0.5 * kRigMisfitBound_m
            ? "the rig values disagree among themselves: | |right_offset_m| - |left_offset_m + base_m| | = " +
                  millimetres(inconsistency_m) + ", so Eq. 3 and Eq. 4 cannot both hold"
            : "the rig values disagree with the images";
    warnings.push_back(eq + " misses its bound after the held-sigma rule: largest misfit " +
                       millimetres(misfit_m) + " > " + millimetres(kRigMisfitBound_m) + " (" + field +
                       " absent); " + why + ".");
  }
}

}  // namespace

std::string heldSigmaNote(const std::string& field) {
  std::ostringstream s;
  s << field << ": absent, " << equationOf(field) << " is held: sigma " << kHeldRigSigma_m
    << " m (a tenth of the " << millimetres(kRigMisfitBound_m)
    << " bound the constraint must meet), tightened by the adjustment while its misfit exceeds half the "
       "bound.";
  return s.str();
}

void applyRigSigmas(const Rig& given, RigConstraints& rig, std::vector<std::string>* notes) {
  rig.hold_gimbal = !given.sigma_gimbal_m.has_value();
  rig.hold_base = !given.sigma_base_m.has_value();
  rig.sigma_gimbal_m = given.sigma_gimbal_m.value_or(kHeldRigSigma_m);
  rig.sigma_base_m = given.sigma_base_m.value_or(kHeldRigSigma_m);
  if (notes == nullptr) return;
  if (rig.hold_gimbal) notes->push_back(heldSigmaNote("rig.sigma_gimbal_m"));
  if (rig.hold_base) notes->push_back(heldSigmaNote("rig.sigma_base_m"));
}

void heldSigmaOutcome(const RigConstraints& rig, const ConstraintMisfit& misfit,
                      std::vector<std::string>& notes, std::vector<std::string>& warnings) {
  const double d = rigInconsistency(rig);
  const ConstraintMisfit floor = misfitFloor(rig);
  outcome("rig.sigma_gimbal_m", rig.use_gimbal && rig.hold_gimbal, rig.sigma_gimbal_m, misfit.gimbal_m,
          floor.gimbal_m, d, notes, warnings);
  outcome("rig.sigma_base_m", rig.use_base && rig.hold_base, rig.sigma_base_m, misfit.base_m, floor.base_m, d,
          notes, warnings);
}

}  // namespace areomap
