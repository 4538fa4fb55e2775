#include "ground/dataset/RigEstimate.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <Eigen/Dense>

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

// The FIDO-style values from the a-priori models.
void estimateFidoVariants(Network& net, RigEstimate& out) {
  RigConstraints& rig = net.rig;
  const int n_img = net.imageCount();
  // FIDO variants: a virtual spin centre per tier (sphere fit |C - S|^2 = d^2 over the tier's centres, both
  // sides, linear in S and d^2 - |S|^2), camera-to-centre distances per side, left-right distance.
  double sum_d[2] = {0.0, 0.0};
  int n_d[2] = {0, 0};
  for (int t = 0; t < kMaxTiers; ++t) {
    std::vector<int> members;
    for (int i = 0; i < n_img; ++i) {
      if (net.image(i).tier == t) members.push_back(i);
    }
    if (members.empty()) continue;
    Eigen::MatrixXd a(members.size(), 4);
    Eigen::VectorXd b(members.size());
    for (size_t k = 0; k < members.size(); ++k) {
      const Vec3 c = net.image(members[k]).centre_apriori_m;
      a.row(k) << 2.0 * c.x(), 2.0 * c.y(), 2.0 * c.z(), 1.0;
      b(k) = c.squaredNorm();
    }
    Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(a);
    const Eigen::Vector4d x = cod.solve(b);
    rig.spin_centre_m[t] = x.head<3>();
    rig.spin_centre_set[t] = true;
    for (int i : members) {
      const int side = net.image(i).side == Side::kLeft ? 0 : 1;
      sum_d[side] += (net.image(i).centre_apriori_m - rig.spin_centre_m[t]).norm();
      ++n_d[side];
    }
    out.estimated.push_back("FIDO: virtual spin centre of tier " + std::to_string(t) + " fitted as " +
                               vecText(rig.spin_centre_m[t]) + ".");
  }
  rig.left_distance_m = n_d[0] > 0 ? sum_d[0] / n_d[0] : 0.0;
  rig.right_distance_m = n_d[1] > 0 ? sum_d[1] / n_d[1] : rig.left_distance_m;
  double lr = 0.0;
  int n_lr = 0;
  for (int p = 0; p < net.pairCount(); ++p) {
    if (net.pair(p).right < 0) continue;
    lr +=
        (net.image(net.pair(p).right).centre_apriori_m - net.image(net.pair(p).left).centre_apriori_m).norm();
    ++n_lr;
  }
  rig.lr_distance_m = n_lr > 0 ? lr / n_lr : 0.0;
  rig.sigma_distance_m = rig.sigma_base_m;
  out.estimated.push_back("FIDO: camera-to-centre distances " + std::to_string(rig.left_distance_m) +
                             " / " + std::to_string(rig.right_distance_m) + " m and left-right distance " +
                             std::to_string(rig.lr_distance_m) + " m from the a-priori models.");
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
