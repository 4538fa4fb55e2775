#include "firmware_core/adjust/RigShape.hpp"

#include <cmath>

namespace areomap {

namespace {

// Eq. 3's design block of an image over the offsets [c_L, c_R]: M^T in its side's columns.
Mat3x6 rigShapeOffsetBlock(const NetImage& im) {
  Mat3x6 a = Mat3x6::Zero();
  a.block<3, 3>(0, im.side == Side::kLeft ? 0 : 3) = im.m_apriori.transpose();
  return a;
}

// Minimum-norm solution of a symmetric positive semi-definite system: eigenvalues below `relative` times
// the largest are taken as zero (directions the data leave free). One eigensolver for every size used here:
// a system of N unknowns is solved inside a kNormalSize one, the rows and columns beyond N zero (their
// eigenvalues are exactly zero, so they take no part), because each fixed-size eigensolver is a template
// instantiation of its own, seconds of compile time for no gain at these sizes.
constexpr int kNormalSize = 7;
using NormalMatrix = Eigen::Matrix<double, kNormalSize, kNormalSize>;
using NormalVector = Eigen::Matrix<double, kNormalSize, 1>;

NormalVector minimumNormSolve(const NormalMatrix& n, const NormalVector& rhs, double relative) {
  const Eigen::SelfAdjointEigenSolver<NormalMatrix> eig(n);
  const double largest = eig.eigenvalues().cwiseAbs().maxCoeff();
  NormalVector x = NormalVector::Zero();
  for (int k = 0; k < kNormalSize; ++k) {
    const double lambda = eig.eigenvalues()(k);
    if (!(lambda > relative * largest)) continue;
    x += eig.eigenvectors().col(k) * (eig.eigenvectors().col(k).dot(rhs) / lambda);
  }
  return x;
}

template <int N>
Eigen::Matrix<double, N, 1> rigShapeMinimumNormSolve(const Eigen::Matrix<double, N, N>& n,
                                                     const Eigen::Matrix<double, N, 1>& rhs, double relative) {
  static_assert(N <= kNormalSize, "kNormalSize bounds the unknowns");
  NormalMatrix padded = NormalMatrix::Zero();
  padded.template topLeftCorner<N, N>() = n;
  NormalVector padded_rhs = NormalVector::Zero();
  padded_rhs.template head<N>() = rhs;
  return minimumNormSolve(padded, padded_rhs, relative).template head<N>();
}

// Eigenvalues of a normal matrix this far below its largest are rounding (the square of a condition of
// 1e5, far beyond any real spread of camera centres around a mast).
constexpr double kRigShapeRelativeRank = 1e-10;

// The least-squares fit of C_i = X_sol + A_i x over the network's a-priori cameras, A_i = block(i) (3 x N):
// each sol's X eliminated (X_sol is the sol's mean of C - A x at any x, so each image enters relative to
// its sol's means), minimum norm over x. Returns x; `rms_m` is the RMS over the images of the residual;
// `centres` (kMaxSols), when given, receive X_sol and `centre_set` which sols have images.
template <int N, typename Block>
Eigen::Matrix<double, N, 1> fitPerSolCentres(const Network& net, const Block& block, double& rms_m,
                                             Vec3* centres = nullptr, bool* centre_set = nullptr) {
  using MatA = Eigen::Matrix<double, 3, N>;
  using VecX = Eigen::Matrix<double, N, 1>;
  using MatN = Eigen::Matrix<double, N, N>;
  const int32_t n_img = net.imageCount();
  Vec3 mean_c[kMaxSols];
  MatA mean_a[kMaxSols];
  int32_t count[kMaxSols] = {};
  for (int32_t s = 0; s < kMaxSols; ++s) {
    mean_c[s].setZero();
    mean_a[s].setZero();
  }
  for (int32_t i = 0; i < n_img; ++i) {
    const NetImage& im = net.image(i);
    mean_c[im.sol] += im.centre_apriori_m;
    mean_a[im.sol] += block(i);
    ++count[im.sol];
  }
  for (int32_t s = 0; s < kMaxSols; ++s) {
    if (count[s] == 0) continue;
    mean_c[s] /= static_cast<double>(count[s]);
    mean_a[s] /= static_cast<double>(count[s]);
  }
  MatN normal = MatN::Zero();
  VecX rhs = VecX::Zero();
  for (int32_t i = 0; i < n_img; ++i) {
    const NetImage& im = net.image(i);
    const MatA a = block(i) - mean_a[im.sol];
    const Vec3 b = im.centre_apriori_m - mean_c[im.sol];
    normal.noalias() += a.transpose() * a;
    rhs.noalias() += a.transpose() * b;
  }
  const VecX x = rigShapeMinimumNormSolve<N>(normal, rhs, kRigShapeRelativeRank);
  double sum_sq = 0.0;
  for (int32_t i = 0; i < n_img; ++i) {
    const NetImage& im = net.image(i);
    const Vec3 r = (im.centre_apriori_m - mean_c[im.sol]) - (block(i) - mean_a[im.sol]) * x;
    sum_sq += r.squaredNorm();
  }
  rms_m = n_img > 0 ? std::sqrt(sum_sq / n_img) : 0.0;
  for (int32_t s = 0; centres != nullptr && s < kMaxSols; ++s) {
    centre_set[s] = count[s] > 0;
    centres[s] = count[s] > 0 ? Vec3(mean_c[s] - mean_a[s] * x) : Vec3::Zero();
  }
  return x;
}

}  // namespace

namespace {

// The eigenvector of a 3x3 scatter matrix with the k-th smallest eigenvalue (0 smallest, 2 largest), and
// whether the next one up stands above rounding (the smallest is then the only direction the data leave).
Vec3 scatterAxis(const Mat3& scatter, int32_t k, bool* unique = nullptr) {
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(scatter);
  if (unique != nullptr) *unique = eig.eigenvalues()(1) > kRigShapeRelativeRank * eig.eigenvalues()(2);
  return eig.eigenvectors().col(k);
}

// Two unit vectors spanning the plane perpendicular to unit v.
Eigen::Matrix<double, 3, 2> tangentBasis(const Vec3& v) {
  const Vec3 other = std::fabs(v.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  Eigen::Matrix<double, 3, 2> t;
  t.col(0) = v.cross(other).normalized();
  t.col(1) = v.cross(t.col(0));
  return t;
}

// Two axes closer than this (rad) are one: far below any pointing a mast's encoders give.
constexpr double kTiltArmAxisTolerance_rad = 1e-12;
// Gauss-Newton below converges quadratically from the start; on pointing-derived cameras it meets the
// tolerance in a few steps. A cap, not a setting.
constexpr int32_t kMaxTiltArmIterations = 100;

// The pan axis (site frame) and each side's tilt axis (camera frame) of the a-priori cameras: a rotation
// between two images of one tier and side is a pan, about the pan axis a (its rotation vectors' principal
// direction starts a); the pan axis in a camera frame, M a, turns only with the tilt, so it stays
// perpendicular to the tilt axis k (the scatter's least direction starts k), and the tilt axis in the site
// frame, M^T k, stays perpendicular to a: a . M_i^T k = 0 for every image, solved for a and both k by
// Gauss-Newton. False when the tilts do not span a plane (one tilt: the arm is then an offset like any
// other, and Eq. 3 holds as it is).
bool fitTiltArmAxes(const Network& net, TiltArm& arm) {
  const int32_t n_img = net.imageCount();
  int32_t first[kMaxTiers][2];
  for (int32_t t = 0; t < kMaxTiers; ++t) first[t][0] = first[t][1] = -1;
  Mat3 pans = Mat3::Zero();
  for (int32_t i = 0; i < n_img; ++i) {
    const NetImage& im = net.image(i);
    int32_t& f = first[im.tier][im.side == Side::kLeft ? 0 : 1];
    if (f < 0) {
      f = i;
      continue;
    }
    const Mat3 turn = im.m_apriori.transpose() * net.image(f).m_apriori;
    const Vec3 v = rotationVector(turn);
    pans.noalias() += v * v.transpose();
  }
  if (!(pans.trace() > 0.0)) return false;
  Vec3 a = scatterAxis(pans, 2);
  bool has_side[2] = {false, false};
  for (int32_t i = 0; i < n_img; ++i) has_side[net.image(i).side == Side::kLeft ? 0 : 1] = true;
  for (int32_t side = 0; side < 2; ++side) {
    if (!has_side[side]) continue;
    Mat3 scatter = Mat3::Zero();
    for (int32_t i = 0; i < n_img; ++i) {
      const NetImage& im = net.image(i);
      if ((im.side == Side::kLeft ? 0 : 1) != side) continue;
      const Vec3 v = im.m_apriori * a;
      scatter.noalias() += v * v.transpose();
    }
    bool unique = false;
    arm.tilt_axis[side] = scatterAxis(scatter, 0, &unique);
    if (!unique) return false;
  }
  // Gauss-Newton on r_i = a . M_i^T k_side over [a, k_L, k_R], each moved in its tangent plane.
  Vec3* axes[3] = {&a, &arm.tilt_axis[0], &arm.tilt_axis[1]};
  for (int32_t it = 0; it < kMaxTiltArmIterations; ++it) {
    Eigen::Matrix<double, 3, 2> tangent[3];
    for (int32_t k = 0; k < 3; ++k) tangent[k] = tangentBasis(*axes[k]);
    Mat6 normal = Mat6::Zero();
    Vec6 rhs = Vec6::Zero();
    for (int32_t i = 0; i < n_img; ++i) {
      const NetImage& im = net.image(i);
      const int32_t side = im.side == Side::kLeft ? 0 : 1;
      const Vec3 k_site = im.m_apriori.transpose() * arm.tilt_axis[side];
      const Vec3 a_cam = im.m_apriori * a;
      Vec6 row = Vec6::Zero();
      row.head<2>() = tangent[0].transpose() * k_site;
      row.segment<2>(2 + 2 * side) = tangent[1 + side].transpose() * a_cam;
      normal.noalias() += row * row.transpose();
      rhs -= row * a.dot(k_site);
    }
    const Vec6 step = rigShapeMinimumNormSolve<6>(normal, rhs, kRigShapeRelativeRank);
    for (int32_t k = 0; k < 3; ++k) *axes[k] = (*axes[k] + tangent[k] * step.segment<2>(2 * k)).normalized();
    if (step.norm() < kTiltArmAxisTolerance_rad) break;
  }
  arm.pan_axis = a;
  // The arm is one for both cameras: their tilt axes are turned to give the same forward direction.
  double agree = 0.0;
  for (int32_t p = 0; p < net.pairCount(); ++p) {
    const NetPair& pr = net.pair(p);
    if (pr.right < 0) continue;
    agree += a.cross(net.image(pr.left).m_apriori.transpose() * arm.tilt_axis[0])
                 .dot(a.cross(net.image(pr.right).m_apriori.transpose() * arm.tilt_axis[1]));
  }
  if (agree < 0.0) arm.tilt_axis[1] = -arm.tilt_axis[1];
  return true;
}

// The forward direction u of an image (Network.hpp TiltArm) at its a-priori rotation.
Vec3 tiltArmForward(const TiltArm& arm, const NetImage& im) {
  const Vec3 w = arm.pan_axis.cross(im.m_apriori.transpose() * arm.tilt_axis[im.side == Side::kLeft ? 0 : 1]);
  const double len = w.norm();
  return len > 0.0 ? Vec3(w / len) : Vec3::Zero();
}

}  // namespace

TiltArmFit fitTiltArm(Network& net) {
  TiltArmFit fit;
  TiltArm& arm = net.rig.tilt_arm;
  for (int32_t s = 0; s < kMaxSols; ++s) arm.centre_set[s] = false;
  if (net.imageCount() == 0 || !fitTiltArmAxes(net, arm)) return fit;
  // C_i - XA_sol = [M_i^T in its side's columns, u_i] [o_L, o_R, arm]: Eq. 3's fit with the arm's column.
  using Block = Eigen::Matrix<double, 3, 7>;
  const auto block = [&net, &arm](int32_t i) {
    const NetImage& im = net.image(i);
    Block a = Block::Zero();
    a.block<3, 3>(0, im.side == Side::kLeft ? 0 : 3) = im.m_apriori.transpose();
    a.col(6) = tiltArmForward(arm, im);
    return a;
  };
  const Eigen::Matrix<double, 7, 1> x =
      fitPerSolCentres<7>(net, block, fit.rms_m, arm.centre_m, arm.centre_set);
  arm.offset_m[0] = x.head<3>();
  arm.offset_m[1] = x.segment<3>(3);
  arm.arm_m = x(6);
  fit.fitted = true;
  fit.arm_m = arm.arm_m;
  return fit;
}

RigShape checkRigShape(const Network& net) {
  RigShape shape;
  const Vec6 offsets = fitPerSolCentres<6>(
      net, [&net](int32_t i) { return rigShapeOffsetBlock(net.image(i)); }, shape.fit_rms_m);
  shape.lever_m = std::fmax(offsets.head<3>().norm(), offsets.tail<3>().norm());
  shape.threshold_m = kRigMisfitBound_m + shape.lever_m * net.rig.sigma_datum_rad;
  shape.one_point = !(shape.fit_rms_m > shape.threshold_m);
  return shape;
}

FidoFit fitFidoRig(Network& net) {
  FidoFit fit;
  RigConstraints& rig = net.rig;
  const int32_t n_img = net.imageCount();
  double sum_d[2] = {0.0, 0.0};
  int32_t n_d[2] = {0, 0};
  for (int32_t t = 0; t < kMaxTiers; ++t) {
    rig.spin_centre_set[t] = false;
    Vec3 mean = Vec3::Zero();
    int32_t n = 0;
    for (int32_t i = 0; i < n_img; ++i) {
      if (net.image(i).tier != t) continue;
      mean += net.image(i).centre_apriori_m;
      ++n;
    }
    if (n < kMinSpinCentreImages) continue;
    mean /= static_cast<double>(n);
    double spread_sq = 0.0;
    for (int32_t i = 0; i < n_img; ++i) {
      if (net.image(i).tier == t) spread_sq += (net.image(i).centre_apriori_m - mean).squaredNorm();
    }
    const double scale = std::sqrt(spread_sq / n);
    if (!(scale > 0.0)) continue;
    // |p - s|^2 = r^2 in the tier's centred, scaled coordinates p: 2 p.s + (r^2 - |s|^2) = |p|^2.
    Eigen::Matrix4d normal = Eigen::Matrix4d::Zero();
    Eigen::Vector4d rhs = Eigen::Vector4d::Zero();
    for (int32_t i = 0; i < n_img; ++i) {
      if (net.image(i).tier != t) continue;
      const Vec3 p = (net.image(i).centre_apriori_m - mean) / scale;
      const Eigen::Vector4d a(2.0 * p.x(), 2.0 * p.y(), 2.0 * p.z(), 1.0);
      normal.noalias() += a * a.transpose();
      rhs += a * p.squaredNorm();
    }
    const Eigen::Vector4d x = rigShapeMinimumNormSolve<4>(normal, rhs, kRigShapeRelativeRank);
    rig.spin_centre_m[t] = mean + scale * x.head<3>();
    rig.spin_centre_set[t] = true;
    ++fit.tiers;
    for (int32_t i = 0; i < n_img; ++i) {
      if (net.image(i).tier != t) continue;
      const int32_t side = net.image(i).side == Side::kLeft ? 0 : 1;
      sum_d[side] += (net.image(i).centre_apriori_m - rig.spin_centre_m[t]).norm();
      ++n_d[side];
    }
  }
  rig.left_distance_m = n_d[0] > 0 ? sum_d[0] / n_d[0] : 0.0;
  rig.right_distance_m = n_d[1] > 0 ? sum_d[1] / n_d[1] : rig.left_distance_m;
  double sum_miss_sq = 0.0;
  for (int32_t i = 0; i < n_img; ++i) {
    const NetImage& im = net.image(i);
    if (!rig.spin_centre_set[im.tier]) continue;
    const double d = im.side == Side::kLeft ? rig.left_distance_m : rig.right_distance_m;
    const double miss = (im.centre_apriori_m - rig.spin_centre_m[im.tier]).norm() - d;
    sum_miss_sq += miss * miss;
  }
  const int32_t fitted = n_d[0] + n_d[1];
  fit.distance_rms_m = fitted > 0 ? std::sqrt(sum_miss_sq / fitted) : 0.0;
  double lr = 0.0;
  for (int32_t p = 0; p < net.pairCount(); ++p) {
    const NetPair& pr = net.pair(p);
    if (pr.right < 0) continue;
    lr += (net.image(pr.right).centre_apriori_m - net.image(pr.left).centre_apriori_m).norm();
    ++fit.lr_pairs;
  }
  rig.lr_distance_m = fit.lr_pairs > 0 ? lr / fit.lr_pairs : 0.0;
  fit.tilt_arm = fitTiltArm(net);
  return fit;
}

void useFidoModel(Network& net) {
  bool has_right = false;
  for (int32_t p = 0; p < net.pairCount(); ++p) has_right = has_right || net.pair(p).right >= 0;
  RigConstraints& rig = net.rig;
  bool arm = false;
  for (int32_t s = 0; s < kMaxSols; ++s) arm = arm || rig.tilt_arm.centre_set[s];
  rig.use_tilt_arm = arm;
  rig.use_gimbal = arm;
  if (arm) {
    rig.hold_gimbal = true;
    rig.sigma_gimbal_m = kHeldRigSigma_m;
  }
  rig.use_spin_centre = !arm;
  rig.use_lr_distance = !arm && has_right;
  rig.use_base = has_right;
  rig.sigma_distance_m = rig.sigma_base_m;
}

}  // namespace areomap
