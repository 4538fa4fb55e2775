#include "ground/dataset/RigEstimate.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <Eigen/Dense>

#include "firmware_core/adjust/RigShape.hpp"
#include "ground/dataset/RigSigmas.hpp"

namespace areomap {

namespace {

std::string vecText(const Vec3& v) {
  std::ostringstream s;
  s.precision(6);
  s << "[" << v.x() << ", " << v.y() << ", " << v.z() << "]";
  return s.str();
}

// Eq. 4's base e: as given, else the mean of M_L (C_R - C_L) over the pairs' a-priori models.
void estimateBase(const Rig& given, Network& net, RigEstimate& out) {
  RigConstraints& rig = net.rig;
  if (given.base_m) {
    rig.base_m = *given.base_m;
  } else {
    Vec3 sum = Vec3::Zero();
    int n = 0;
    for (int p = 0; p < net.pairCount(); ++p) {
      const NetPair& pr = net.pair(p);
      if (pr.right < 0) continue;
      sum += net.image(pr.left).m_apriori *
             (net.image(pr.right).centre_apriori_m - net.image(pr.left).centre_apriori_m);
      ++n;
    }
    rig.base_m = n > 0 ? Vec3(sum / n) : Vec3::Zero();
    if (n > 0)  // a mono panorama has no base to hold
      out.estimated.push_back("rig.base_m: absent, estimated from the a-priori models as " +
                              vecText(rig.base_m) + " (mean of M_L (C_R - C_L) over " + std::to_string(n) +
                              " pairs).");
  }
}

// Eq. 3's gimbal centre per sol and camera offsets c: the given ones kept, the missing ones fitted to the
// a-priori models.
void estimateGimbalAndOffsets(const Rig& given, const std::vector<int>& sol_of_index, Network& net,
                              RigEstimate& out) {
  RigConstraints& rig = net.rig;
  const int n_sols = static_cast<int>(sol_of_index.size());
  const int n_img = net.imageCount();
  // Gimbal centres and offsets: linear least squares of C_i - M_i^T c_side - XG_sol = 0 over the unknowns
  // that are missing (given ones are constants).
  std::vector<bool> gimbal_given(n_sols, false);
  for (int s = 0; s < n_sols; ++s) {
    const auto it = given.gimbal_m.find(sol_of_index[s]);
    if (it != given.gimbal_m.end()) {
      rig.gimbal_m[s] = it->second;
      gimbal_given[s] = true;
    }
    rig.gimbal_set[s] = true;
  }
  const bool offsets_given[2] = {given.left_offset_m.has_value(), given.right_offset_m.has_value()};
  if (offsets_given[0]) rig.left_offset_m = *given.left_offset_m;
  if (offsets_given[1]) rig.right_offset_m = *given.right_offset_m;
  std::vector<int> col_gimbal(n_sols, -1);
  int cols = 0;
  for (int s = 0; s < n_sols; ++s) {
    if (!gimbal_given[s]) {
      col_gimbal[s] = cols;
      cols += 3;
    }
  }
  // A side without images (a mono panorama) has no offset to fit.
  bool has_side[2] = {false, false};
  for (int i = 0; i < n_img; ++i) has_side[net.image(i).side == Side::kLeft ? 0 : 1] = true;
  int col_offset[2] = {-1, -1};
  for (int side = 0; side < 2; ++side) {
    if (!offsets_given[side] && has_side[side]) {
      col_offset[side] = cols;
      cols += 3;
    }
  }
  if (cols > 0 && n_img > 0) {
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(3 * n_img, cols);
    Eigen::VectorXd b(3 * n_img);
    // Fitted relative to the mean camera centre: the minimum-norm choice below must not depend on where
    // the frame's origin lies (a site frame's origin can be hundreds of metres from the rover).
    Vec3 mean_centre = Vec3::Zero();
    for (int i = 0; i < n_img; ++i) mean_centre += net.image(i).centre_apriori_m;
    mean_centre /= static_cast<double>(n_img);
    for (int i = 0; i < n_img; ++i) {
      const NetImage& im = net.image(i);
      const int side = im.side == Side::kLeft ? 0 : 1;
      Vec3 rhs = im.centre_apriori_m - mean_centre;
      if (col_gimbal[im.sol] >= 0) {
        a.block<3, 3>(3 * i, col_gimbal[im.sol]) = Mat3::Identity();
      } else {
        rhs -= rig.gimbal_m[im.sol] - mean_centre;
      }
      if (col_offset[side] >= 0) {
        a.block<3, 3>(3 * i, col_offset[side]) = im.m_apriori.transpose();
      } else {
        rhs -= im.m_apriori.transpose() * (side == 0 ? rig.left_offset_m : rig.right_offset_m);
      }
      b.segment<3>(3 * i) = rhs;
    }
    // Minimum norm: a panorama that only pans leaves the vertical offset and gimbal height in trade-off.
    Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(a);
    cod.setThreshold(1e-9);
    const Eigen::VectorXd x = cod.solve(b);
    const double rms = std::sqrt((a * x - b).squaredNorm() / std::max(1, 3 * n_img));
    for (int s = 0; s < n_sols; ++s) {
      if (col_gimbal[s] < 0) continue;
      rig.gimbal_m[s] = x.segment<3>(col_gimbal[s]) + mean_centre;
      out.estimated.push_back("rig.gimbal_m[" + std::to_string(sol_of_index[s]) +
                                 "]: absent, fitted to the a-priori camera centres as " +
                                 vecText(rig.gimbal_m[s]) + ".");
    }
    for (int side = 0; side < 2; ++side) {
      if (col_offset[side] < 0) continue;
      Vec3& off = side == 0 ? rig.left_offset_m : rig.right_offset_m;
      off = x.segment<3>(col_offset[side]);
      out.estimated.push_back(std::string(side == 0 ? "rig.left_offset_m" : "rig.right_offset_m") +
                                 ": absent, fitted to the a-priori models as " + vecText(off) + ".");
    }
    if (cod.rank() < cols) {
      out.warnings.push_back("The rig fit is rank deficient (rank " + std::to_string(cod.rank()) + " of " +
                                std::to_string(cols) + "): the minimum-norm rig was used.");
    }
    std::ostringstream s;
    s << "The rig fit leaves " << rms * 1000.0 << " mm RMS at the a-priori camera centres.";
    out.estimated.push_back(s.str());
    out.fit_rms_m = rms;
  }
}

// The FIDO-style values from the a-priori models (firmware_core/adjust/RigShape.hpp, the rover's fit).
void estimateFidoVariants(Network& net, RigEstimate& out) {
  RigConstraints& rig = net.rig;
  const FidoFit fit = fitFidoRig(net);
  rig.sigma_distance_m = rig.sigma_base_m;
  for (int t = 0; t < kMaxTiers; ++t) {
    if (!rig.spin_centre_set[t]) continue;
    out.estimated.push_back("FIDO: virtual spin centre of tier " + std::to_string(t) + " fitted as " +
                            vecText(rig.spin_centre_m[t]) + ".");
  }
  std::ostringstream s;
  s << "FIDO: camera-to-centre distances " << rig.left_distance_m << " / " << rig.right_distance_m
    << " m (" << fit.tiers << " tiers, " << fit.distance_rms_m * 1000.0
    << " mm RMS at the a-priori centres) and left-right distance " << rig.lr_distance_m << " m ("
    << fit.lr_pairs << " pairs) from the a-priori models.";
  out.estimated.push_back(s.str());
  const TiltArm& arm = rig.tilt_arm;
  if (!fit.tilt_arm.fitted) {
    out.estimated.push_back(
        "FIDO: the tilts do not fix the mast's axes: no tilt arm, the distances are used.");
    return;
  }
  std::ostringstream a;
  a << "FIDO: Eq. 3 with the tilt arm fitted to the a-priori models: pan axis " << vecText(arm.pan_axis)
    << ", tilt axis " << vecText(arm.tilt_axis[0]) << " (left camera frame), arm " << arm.arm_m
    << " m, offsets " << vecText(arm.offset_m[0]) << " / " << vecText(arm.offset_m[1]) << " m; "
    << fit.tilt_arm.rms_m * 1000.0 << " mm RMS at the a-priori centres.";
  out.estimated.push_back(a.str());
}

// A sol seen by one pair alone: its gimbal centre cannot be estimated (its two camera centres fix the
// offsets' sum, not where the mast turns). Eq. 3 stays with the minimum-norm centre between the cameras: it
// then holds only the pair's position (the network's free translation, which nothing else fixes) and
// couples a rotation of a camera to a shift of its centre by the lever of the offset; the stereo base
// (Eq. 4) is the pair's real constraint. Said in the report.
void noteLonePairs(const Rig& given, const std::vector<int>& sol_of_index, const Network& net,
                   RigEstimate& out) {
  std::vector<int> pairs_of_sol(sol_of_index.size(), 0);
  for (int32_t p = 0; p < net.pairCount(); ++p) ++pairs_of_sol[net.image(net.pair(p).left).sol];
  for (std::size_t s = 0; s < sol_of_index.size(); ++s) {
    if (pairs_of_sol[s] >= 2 || given.gimbal_m.count(sol_of_index[s]) > 0) continue;
    out.estimated.push_back(
        "sol " + std::to_string(sol_of_index[s]) +
        ": one pair alone: its gimbal centre cannot be estimated; the minimum-norm centre between its "
        "cameras only holds the pair's position (Eq. 3), the stereo base is its constraint");
  }
}

}  // namespace

RigEstimate estimateRig(const Rig& given, const std::vector<int>& sol_of_index, Network& net, bool fido) {
  RigEstimate out;
  applyRigSigmas(given, net.rig, &out.estimated);
  estimateBase(given, net, out);
  estimateGimbalAndOffsets(given, sol_of_index, net, out);
  noteLonePairs(given, sol_of_index, net, out);
  if (fido) estimateFidoVariants(net, out);
  return out;
}

}  // namespace areomap
