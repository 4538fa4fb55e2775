#include "ground/ties/TieAdjust.hpp"

#include <cmath>
#include <map>

#include <Eigen/Dense>

#include "ground/dataset/RigSigmas.hpp"

namespace areomap {

void setRigConstraints(const Dataset& dataset, const std::vector<int>& sol_of_index, Network& net,
                       std::vector<std::string>& notes) {
  RigConstraints& rig = net.rig;
  // Least squares for (G per sol, c_L, c_R): C_i = G_sol + M_i^T c_side, minimum norm (a rotation about a
  // single axis leaves the offset along it free). The centres are taken relative to their mean, so that the
  // minimum-norm choice does not depend on where the frame's origin lies (a site frame's origin can be
  // hundreds of metres from the rover).
  const int nsol = static_cast<int>(sol_of_index.size());
  const int unknowns = 3 * nsol + 6;
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(3 * net.imageCount(), unknowns);
  Eigen::VectorXd y(3 * net.imageCount());
  bool has_right = false;
  Vec3 mean_center = Vec3::Zero();
  for (int32_t i = 0; i < net.imageCount(); ++i) mean_center += net.image(i).center_apriori_m;
  if (net.imageCount() > 0) mean_center /= static_cast<double>(net.imageCount());
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    const NetImage& im = net.image(i);
    const int side = im.side == Side::kLeft ? 0 : 1;
    has_right = has_right || side == 1;
    a.block<3, 3>(3 * i, 3 * im.sol) = Eigen::Matrix3d::Identity();
    a.block<3, 3>(3 * i, 3 * nsol + 3 * side) = im.m_apriori.transpose();
    y.segment<3>(3 * i) = im.center_apriori_m - mean_center;
  }
  Eigen::VectorXd x = a.completeOrthogonalDecomposition().solve(y);
  for (int s = 0; s < nsol; ++s) x.segment<3>(3 * s) += mean_center;
  const bool offsets_given =
      dataset.rig.left_offset_m.has_value() && (!has_right || dataset.rig.right_offset_m);
  rig.left_offset_m = offsets_given ? *dataset.rig.left_offset_m : Vec3(x.segment<3>(3 * nsol));
  rig.right_offset_m =
      offsets_given && has_right ? *dataset.rig.right_offset_m : Vec3(x.segment<3>(3 * nsol + 3));
  if (!offsets_given) notes.push_back("camera offsets estimated from the a-priori models");
  // Pairs per sol: the gimbal centre of a sol seen by one pair alone cannot be estimated (its two camera
  // centres fix the offsets' sum, not where the mast turns). Eq. 3 stays, with the minimum-norm centre
  // (between the cameras): it then holds only the pair's position (the network's free translation, which
  // nothing else fixes) and couples a rotation of a camera to a shift of its centre by the ~0.2 m lever,
  // 0.2 mm per mrad; the stereo base (Eq. 4) is the pair's real constraint. Said in the report.
  std::vector<int> pairs_of_sol(static_cast<std::size_t>(nsol), 0);
  for (int32_t p = 0; p < net.pairCount(); ++p) ++pairs_of_sol[net.image(net.pair(p).left).sol];
  for (int s = 0; s < nsol; ++s) {
    auto it = dataset.rig.gimbal_m.find(sol_of_index[s]);
    rig.gimbal_set[s] = true;
    if (it == dataset.rig.gimbal_m.end() && pairs_of_sol[s] < 2) {
      notes.push_back(
          "sol " + std::to_string(sol_of_index[s]) +
          ": one pair alone: its gimbal centre cannot be estimated; the minimum-norm centre between "
          "its cameras only holds the pair's position (Eq. 3), the stereo base is its constraint");
    }
    if (it != dataset.rig.gimbal_m.end() && offsets_given) {
      rig.gimbal_m[s] = it->second;
    } else {
      rig.gimbal_m[s] = x.segment<3>(3 * s);
      notes.push_back("gimbal centre of sol " + std::to_string(sol_of_index[s]) +
                      " estimated from the a-priori models");
    }
  }
  rig.use_base = has_right;
  if (has_right) {
    if (dataset.rig.base_m) {
      rig.base_m = *dataset.rig.base_m;
    } else {
      Vec3 sum = Vec3::Zero();
      int n = 0;
      for (int32_t p = 0; p < net.pairCount(); ++p) {
        if (net.pair(p).right < 0) continue;
        const NetImage& l = net.image(net.pair(p).left);
        const NetImage& r = net.image(net.pair(p).right);
        sum += l.m_apriori * (r.center_apriori_m - l.center_apriori_m);
        ++n;
      }
      rig.base_m = n > 0 ? Vec3(sum / n) : Vec3::Zero();
      notes.push_back("stereo base estimated from the a-priori models");
    }
  }
  applyRigSigmas(dataset.rig, rig, &notes);
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
