#include "firmware_core/adjust/Constraints.hpp"

#include <cmath>

namespace areomap {

namespace {
void tagRows(ConstraintKind* kinds, int32_t first, int32_t count, ConstraintKind kind) {
  if (kinds == nullptr) return;
  for (int32_t r = first; r < first + count; ++r) kinds[r] = kind;
}
}  // namespace

// Eq. 3, the gimbal constraint of one image: g = C - XG - M^T c (c = camera centre minus gimbal centre in
// the camera frame); dg/dC = I, dg/ddelta = d(-M'^T c) with M'^T = M^T exp(-[delta]x): -M^T [c]x.
void gimbalRows(const Vec3& c, const Mat3& m, const Vec3& xg, const Vec3& offset, Vec3& g, Mat3x6& j) {
  Vec3 rc;
  rc.noalias() = m.transpose() * offset;
  g = c - xg - rc;
  j.block<3, 3>(0, 0).setIdentity();
  j.block<3, 3>(0, 3).noalias() = -(m.transpose() * skew(offset));
}

void tiltArmRows(const TiltArm& arm, int32_t side, int32_t sol, const Vec3& c, const Mat3& m, Vec3& g,
                 Mat3x6& j) {
  gimbalRows(c, m, arm.centre_m[sol], arm.offset_m[side], g, j);
  const Vec3 k_site = m.transpose() * arm.tilt_axis[side];
  const Vec3 w = arm.pan_axis.cross(k_site);
  const double len = w.norm();
  if (!(len > 0.0)) return;  // a camera looking along the pan axis: no pan direction (never on a mast)
  const Vec3 u = w / len;
  g -= arm.arm_m * u;
  const Mat3 du = (Mat3::Identity() - u * u.transpose()) / len;
  j.block<3, 3>(0, 3).noalias() -=
      arm.arm_m * du * skew(arm.pan_axis) * m.transpose() * skew(arm.tilt_axis[side]);
}

// Eq. 4, the stereo-base constraint of one pair: g = C_R - C_L - M_L^T e (e = C_R - C_L in the left camera
// frame); over the pair's unknowns [left dC, left delta, right dC, right delta]: dg/dC_L = -I,
// dg/ddelta_L = -M_L^T [e]x (as in Eq. 3), dg/dC_R = I, dg/ddelta_R = 0.
void baseRows(const Vec3& c_left, const Mat3& m_left, const Vec3& c_right, const Vec3& base, Vec3& g,
              Mat3x12& j) {
  Vec3 re;
  re.noalias() = m_left.transpose() * base;
  g = c_right - c_left - re;
  j.setZero();
  j.block<3, 3>(0, 0) = -Mat3::Identity();
  j.block<3, 3>(0, 3).noalias() = -(m_left.transpose() * skew(base));
  j.block<3, 3>(0, 6).setIdentity();
}

int32_t pairConstraintRows(const Network& net, int32_t pair, const Vec3& c_left, const Mat3& m_left,
                           const Vec3& c_right, const Mat3& m_right, ConstraintRows& rows,
                           ConstraintJacobian& jacobian, ConstraintMisfit* misfit, ConstraintKind* kinds) {
  rows.setZero();
  jacobian.setZero();
  if (misfit != nullptr) *misfit = ConstraintMisfit{};
  const RigConstraints& rig = net.rig;
  const NetPair& p = net.pair(pair);
  const bool has_right = p.right >= 0;
  const NetImage& left = net.image(p.left);
  int32_t n = 0;
  const int32_t sides = has_right ? 2 : 1;
  const Vec3* centres[2] = {&c_left, &c_right};
  const Mat3* ms[2] = {&m_left, &m_right};
  const Vec3* offsets[2] = {&rig.left_offset_m, &rig.right_offset_m};
  const double distances[2] = {rig.left_distance_m, rig.right_distance_m};

  const bool arm = rig.use_tilt_arm && rig.tilt_arm.centre_set[left.sol];
  if (rig.use_gimbal && (arm || (!rig.use_tilt_arm && rig.gimbal_set[left.sol])) &&
      rig.sigma_gimbal_m > 0.0) {
    const double w = 1.0 / rig.sigma_gimbal_m;
    for (int32_t s = 0; s < sides; ++s) {
      Vec3 g;
      Mat3x6 j;
      if (arm) {
        tiltArmRows(rig.tilt_arm, s, left.sol, *centres[s], *ms[s], g, j);
      } else {
        gimbalRows(*centres[s], *ms[s], rig.gimbal_m[left.sol], *offsets[s], g, j);
      }
      rows.segment<3>(n) = g * w;
      jacobian.block<3, 6>(n, 6 * s) = j * w;
      tagRows(kinds, n, 3, ConstraintKind::kGimbal);
      n += 3;
      if (misfit != nullptr) misfit->gimbal_m = std::fmax(misfit->gimbal_m, g.norm());
    }
  }
  if (has_right && rig.use_base && rig.sigma_base_m > 0.0) {
    const double w = 1.0 / rig.sigma_base_m;
    Vec3 g;
    Mat3x12 j;
    baseRows(c_left, m_left, c_right, rig.base_m, g, j);
    rows.segment<3>(n) = g * w;
    jacobian.block<3, 12>(n, 0) = j * w;
    tagRows(kinds, n, 3, ConstraintKind::kBase);
    n += 3;
    if (misfit != nullptr) misfit->base_m = g.norm();
  }
  if (rig.use_spin_centre && rig.spin_centre_set[left.tier] && rig.sigma_distance_m > 0.0) {
    const double w = 1.0 / rig.sigma_distance_m;
    for (int32_t s = 0; s < sides; ++s) {
      const Vec3 d = *centres[s] - rig.spin_centre_m[left.tier];
      const double len = d.norm();
      if (len > 0.0) {
        rows(n) = (len - distances[s]) * w;
        jacobian.block<1, 3>(n, 6 * s) = d.transpose() / len * w;
        if (misfit != nullptr)
          misfit->distance_m = std::fmax(misfit->distance_m, std::fabs(len - distances[s]));
      }
      tagRows(kinds, n, 1, ConstraintKind::kSpinCentre);
      n += 1;
    }
  }
  if (has_right && rig.use_lr_distance && rig.sigma_distance_m > 0.0) {
    const double w = 1.0 / rig.sigma_distance_m;
    const Vec3 d = c_right - c_left;
    const double len = d.norm();
    if (len > 0.0) {
      rows(n) = (len - rig.lr_distance_m) * w;
      jacobian.block<1, 3>(n, 0) = -d.transpose() / len * w;
      jacobian.block<1, 3>(n, 6) = d.transpose() / len * w;
      if (misfit != nullptr)
        misfit->distance_m = std::fmax(misfit->distance_m, std::fabs(len - rig.lr_distance_m));
    }
    tagRows(kinds, n, 1, ConstraintKind::kLrDistance);
    n += 1;
  }
  if (rig.use_datum_prior && rig.sigma_datum_rad > 0.0) {
    const double w = 1.0 / rig.sigma_datum_rad;
    const int32_t images[2] = {p.left, p.right};
    for (int32_t s = 0; s < sides; ++s) {
      Mat3 d;
      d.noalias() = (*ms[s]) * net.image(images[s]).m_apriori.transpose();
      rows.segment<3>(n) = rotationVector(d) * w;
      jacobian.block<3, 3>(n, 6 * s + 3) = Mat3::Identity() * w;
      tagRows(kinds, n, 3, ConstraintKind::kDatumPrior);
      n += 3;
    }
  }
  return n;
}

int32_t currentPairConstraintRows(const Network& net, int32_t pair, ConstraintRows& rows,
                                  ConstraintJacobian& jacobian, ConstraintMisfit* misfit,
                                  ConstraintKind* kinds) {
  const NetPair& pr = net.pair(pair);
  const NetImage& l = net.image(pr.left);
  const NetImage& r = net.image(pr.right >= 0 ? pr.right : pr.left);
  return pairConstraintRows(net, pair, l.centre_m, l.m, r.centre_m, r.m, rows, jacobian, misfit, kinds);
}

bool isMeasurement(const RigConstraints& rig, ConstraintKind kind) {
  switch (kind) {
    case ConstraintKind::kGimbal:
      return !rig.hold_gimbal;
    case ConstraintKind::kBase:
      return !rig.hold_base;
    case ConstraintKind::kSpinCentre:
    case ConstraintKind::kLrDistance:
      return true;
    case ConstraintKind::kDatumPrior:
      return false;
  }
  return true;
}

int32_t nonMeasurementRows(const Network& net, int32_t pair, ConstraintJacobian& jacobian) {
  ConstraintRows rows;
  ConstraintJacobian all;
  ConstraintKind kinds[kMaxPairConstraintRows];
  const int32_t n = currentPairConstraintRows(net, pair, rows, all, nullptr, kinds);
  jacobian.setZero();
  int32_t kept = 0;
  for (int32_t r = 0; r < n; ++r) {
    if (!isMeasurement(net.rig, kinds[r])) jacobian.row(kept++) = all.row(r);
  }
  return kept;
}

ConstraintMisfit networkMisfit(const Network& net) {
  ConstraintMisfit worst;
  for (int32_t p = 0; p < net.pairCount(); ++p) {
    ConstraintRows rows;
    ConstraintJacobian jac;
    ConstraintMisfit misfit;
    (void)currentPairConstraintRows(net, p, rows, jac, &misfit);
    worst.gimbal_m = std::fmax(worst.gimbal_m, misfit.gimbal_m);
    worst.base_m = std::fmax(worst.base_m, misfit.base_m);
    worst.distance_m = std::fmax(worst.distance_m, misfit.distance_m);
  }
  return worst;
}

double rigInconsistency(const RigConstraints& rig) {
  if (!rig.use_gimbal || !rig.use_base) return 0.0;
  // With the tilt arm the loop closes the same way: the arm's term is common to both cameras of a pair.
  const Vec3& left = rig.use_tilt_arm ? rig.tilt_arm.offset_m[0] : rig.left_offset_m;
  const Vec3& right = rig.use_tilt_arm ? rig.tilt_arm.offset_m[1] : rig.right_offset_m;
  return std::fabs(right.norm() - (left + rig.base_m).norm());
}

ConstraintMisfit misfitFloor(const RigConstraints& rig) {
  ConstraintMisfit floor;
  const double d = rigInconsistency(rig);
  const double g2 = rig.sigma_gimbal_m * rig.sigma_gimbal_m;
  const double b2 = rig.sigma_base_m * rig.sigma_base_m;
  if (!(d > 0.0) || !(rig.sigma_gimbal_m > 0.0) || !(rig.sigma_base_m > 0.0)) return floor;
  floor.gimbal_m = g2 * d / (2.0 * g2 + b2);
  floor.base_m = b2 * d / (2.0 * g2 + b2);
  return floor;
}

namespace {

// One held sigma: scaled so that the part of the misfit above the rig's own floor, taken as linear in sigma
// (the noise bound of Network.hpp), lands at a quarter of the bound; false when that part is within half
// the bound or the sigma is at its floor already.
bool tightenSigma(bool held, double misfit_m, double floor_m, double& sigma_m) {
  const double reducible_m = misfit_m - floor_m;
  if (!held || !(reducible_m > 0.5 * kRigMisfitBound_m) || !(sigma_m > kMinHeldRigSigma_m)) return false;
  sigma_m = std::fmax(kMinHeldRigSigma_m, sigma_m * (0.25 * kRigMisfitBound_m) / reducible_m);
  return true;
}

}  // namespace

bool tightenHeldSigmas(RigConstraints& rig, const ConstraintMisfit& misfit) {
  const ConstraintMisfit floor = misfitFloor(rig);
  const bool gimbal =
      tightenSigma(rig.use_gimbal && rig.hold_gimbal, misfit.gimbal_m, floor.gimbal_m, rig.sigma_gimbal_m);
  const bool base =
      tightenSigma(rig.use_base && rig.hold_base, misfit.base_m, floor.base_m, rig.sigma_base_m);
  return gimbal || base;
}

bool heldConstraintsMet(const RigConstraints& rig, const ConstraintMisfit& misfit) {
  const bool gimbal = !(rig.use_gimbal && rig.hold_gimbal) || misfit.gimbal_m <= kRigMisfitBound_m;
  const bool base = !(rig.use_base && rig.hold_base) || misfit.base_m <= kRigMisfitBound_m;
  return gimbal && base;
}

Status observationRow(const NetObservation& obs, const NetImage& image, const Vec3& centre, const Mat3& m,
                      const Vec3& point, Vec2& residual, Mat2x6* d_image, Mat2x3* d_point) {
  // d(pixel)/dC = -d(pixel)/dX: the centre block is the negated point block, not computed twice.
  Vec2 pixel;
  Mat2x3 d_rotation, d_xyz;
  const bool derivatives = d_image != nullptr || d_point != nullptr;
  const Status s = collinearity(image.io, centre, m, point, pixel, nullptr,
                                d_image != nullptr ? &d_rotation : nullptr, derivatives ? &d_xyz : nullptr);
  if (!ok(s)) {
    return s;
  }
  const double w = 1.0 / obs.sigma_px;
  residual = (obs.ideal_px - pixel) * w;
  if (d_image != nullptr) {
    d_image->block<2, 3>(0, 0) = d_xyz * (-w);
    d_image->block<2, 3>(0, 3) = d_rotation * w;
  }
  if (d_point != nullptr) {
    *d_point = d_xyz * w;
  }
  return Status::kOk;
}

void applyCameraUpdate(const Vec6& update, Vec3& centre, Mat3& m) {
  centre += update.head<3>();
  const Mat3 r = rotationFromVector(update.tail<3>());
  const Mat3 m_old = m;
  m.noalias() = r * m_old;
  // Re-orthonormalise against drift over thousands of updates.
  const Eigen::Quaterniond q(m);
  m = q.normalized().toRotationMatrix();
}

}  // namespace areomap
