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
// the largest are taken as zero (directions the data leave free).
template <int N>
Eigen::Matrix<double, N, 1> rigShapeMinimumNormSolve(const Eigen::Matrix<double, N, N>& n,
                                             const Eigen::Matrix<double, N, 1>& rhs, double relative) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>> eig(n);
  const double largest = eig.eigenvalues().cwiseAbs().maxCoeff();
  Eigen::Matrix<double, N, 1> x = Eigen::Matrix<double, N, 1>::Zero();
  for (int k = 0; k < N; ++k) {
    const double lambda = eig.eigenvalues()(k);
    if (!(lambda > relative * largest)) continue;
    x += eig.eigenvectors().col(k) * (eig.eigenvectors().col(k).dot(rhs) / lambda);
  }
  return x;
}

// Eigenvalues of a normal matrix this far below its largest are rounding (the square of a condition of
// 1e5, far beyond any real spread of camera centres around a mast).
constexpr double kRigShapeRelativeRank = 1e-10;

}  // namespace

RigShape checkRigShape(const Network& net) {
  RigShape shape;
  const int32_t n_img = net.imageCount();
  // Per sol: the mean centre and the mean design block (the gimbal centre eliminated: XG_sol is the sol's
  // mean of C - M^T c at any offsets, so each image enters relative to its sol's means).
  Vec3 mean_c[kMaxSols];
  Mat3x6 mean_a[kMaxSols];
  int32_t count[kMaxSols] = {};
  for (int32_t s = 0; s < kMaxSols; ++s) {
    mean_c[s].setZero();
    mean_a[s].setZero();
  }
  for (int32_t i = 0; i < n_img; ++i) {
    const NetImage& im = net.image(i);
    mean_c[im.sol] += im.centre_apriori_m;
    mean_a[im.sol] += rigShapeOffsetBlock(im);
    ++count[im.sol];
  }
  for (int32_t s = 0; s < kMaxSols; ++s) {
    if (count[s] == 0) continue;
    mean_c[s] /= static_cast<double>(count[s]);
    mean_a[s] /= static_cast<double>(count[s]);
  }
  Mat6 normal = Mat6::Zero();
  Vec6 rhs = Vec6::Zero();
  for (int32_t i = 0; i < n_img; ++i) {
    const NetImage& im = net.image(i);
    const Mat3x6 a = rigShapeOffsetBlock(im) - mean_a[im.sol];
    const Vec3 b = im.centre_apriori_m - mean_c[im.sol];
    normal.noalias() += a.transpose() * a;
    rhs.noalias() += a.transpose() * b;
  }
  const Vec6 offsets = rigShapeMinimumNormSolve<6>(normal, rhs, kRigShapeRelativeRank);
  double sum_sq = 0.0;
  for (int32_t i = 0; i < n_img; ++i) {
    const NetImage& im = net.image(i);
    const Vec3 r = (im.centre_apriori_m - mean_c[im.sol]) - (rigShapeOffsetBlock(im) - mean_a[im.sol]) * offsets;
    sum_sq += r.squaredNorm();
  }
  shape.fit_rms_m = n_img > 0 ? std::sqrt(sum_sq / n_img) : 0.0;
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
  return fit;
}

void useFidoModel(Network& net) {
  bool has_right = false;
  for (int32_t p = 0; p < net.pairCount(); ++p) has_right = has_right || net.pair(p).right >= 0;
  RigConstraints& rig = net.rig;
  rig.use_gimbal = false;
  rig.use_spin_centre = true;
  rig.use_lr_distance = has_right;
  rig.use_base = has_right;
  rig.sigma_distance_m = rig.sigma_base_m;
}

}  // namespace areomap
