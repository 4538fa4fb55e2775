#include "ground/adjust/CommonVergence.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "firmware_core/adjust/FastAdjuster.hpp"

namespace areomap::ground {

Eigen::VectorXd commonVergenceFunctional(const Network& net) {
  Eigen::VectorXd a = Eigen::VectorXd::Zero(12 * net.pairCount());
  int stereo = 0;
  for (int32_t p = 0; p < net.pairCount(); ++p) stereo += net.pair(p).right >= 0 ? 1 : 0;
  if (stereo == 0) return a;
  for (int32_t p = 0; p < net.pairCount(); ++p) {
    const NetPair& pr = net.pair(p);
    if (pr.right < 0) continue;
    // The right camera against the left one: delta_R - (M_R M_L^T) delta_L (local updates M' = exp M),
    // its y component.
    const Mat3 q = net.image(pr.right).m * net.image(pr.left).m.transpose();
    a(12 * p + 10) = 1.0 / stereo;
    a.segment<3>(12 * p + 3) = -q.row(1).transpose() / stereo;
  }
  return a;
}

double commonVergenceDifference(const Network& a, const Network& b) {
  double sum = 0.0;
  int stereo = 0;
  for (int32_t p = 0; p < a.pairCount(); ++p) {
    const NetPair& pr = a.pair(p);
    if (pr.right < 0) continue;
    const Mat3 qa = a.image(pr.right).m * a.image(pr.left).m.transpose();
    const Mat3 qb = b.image(pr.right).m * b.image(pr.left).m.transpose();
    sum += rotationVector(qb * qa.transpose()).y();
    ++stereo;
  }
  return stereo > 0 ? sum / stereo : 0.0;
}

namespace {

// Var(a^T (e_near - e_all)) under the images' noise alone: e = S^-1 J^T W eps for each solution (the
// constraint rows that are no measurement carry no noise), so with A = S - P the information of the
// measurements, Cov(e_near, e_all) = S_near^-1 A_near S_all^-1 (the near measurements are a subset of all).
// Not C_near - C_all: the held rig rows and the datum prior make the estimator a constrained (regularised)
// one, and in a mode they hold as firmly as the data do, more data can widen it (measured:
// tests/ground/adjust/CommonVergenceTest.cpp).
double differenceVariance(const FullEoCovariance& all, const FullEoCovariance& near,
                          const Eigen::VectorXd& a) {
  const Eigen::VectorXd xa = all.inverse * a, xn = near.inverse * a;
  const Eigen::MatrixXd s_near = near.inverse.fullPivLu().inverse();
  const Eigen::MatrixXd s_all = all.inverse.fullPivLu().inverse();
  const Eigen::VectorXd an_xn = s_near * xn - near.fixed * xn;
  const Eigen::VectorXd aa_xa = s_all * xa - all.fixed * xa;
  const double v = near.sigma0 * near.sigma0 * xn.dot(an_xn) + all.sigma0 * all.sigma0 * xa.dot(aa_xa) -
                   2.0 * near.sigma0 * all.sigma0 * an_xn.dot(xa);
  return std::max(0.0, v);
}

}  // namespace

CommonVergenceCheck addCommonVergenceSystematic(const Network& solved, FullEoCovariance& full) {
  CommonVergenceCheck check;
  const Eigen::VectorXd a = commonVergenceFunctional(solved);
  int stereo = 0;
  for (int32_t p = 0; p < solved.pairCount(); ++p) stereo += solved.pair(p).right >= 0 ? 1 : 0;
  if (stereo < 2 || !ok(full.status) || full.covariance.rows() != a.size()) return check;
  // The near half: the points beyond the median range (from the first gimbal centre) left out.
  const Vec3 g = solved.rig.gimbal_m[0];
  std::vector<double> range(static_cast<std::size_t>(solved.pointCount()));
  for (int32_t p = 0; p < solved.pointCount(); ++p) range[p] = (solved.point(p).xyz_m - g).head<2>().norm();
  if (range.size() < 2) return check;
  std::vector<double> sorted = range;
  const auto mid = sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2);
  std::nth_element(sorted.begin(), mid, sorted.end());
  check.split_range_m = *mid;
  const auto near = std::make_unique<Network>(solved);
  for (int32_t k = 0; k < near->observationCount(); ++k) {
    NetObservation& o = near->observation(k);
    if (range[static_cast<std::size_t>(o.point)] > check.split_range_m) o.rejected = true;
  }
  const auto adjuster = std::make_unique<FastAdjuster>();
  FastAdjustOptions options;
  options.robust = false;  // the same observations as the full solution, less the far half
  FastAdjustResult result;
  if (!ok(adjuster->adjust(*near, options, result))) return check;
  const FullEoCovariance near_full = fullEoCovariance(*near);
  if (!ok(near_full.status)) return check;
  const Eigen::VectorXd ca = full.covariance * a;
  const double var_all = a.dot(ca);
  if (!(var_all > 0.0)) return check;
  check.sigma_rad = std::sqrt(var_all);
  check.difference_rad = commonVergenceDifference(*near, solved);
  check.expected_sd_rad = std::sqrt(differenceVariance(full, near_full, a));
  const double s2 = std::max(
      0.0, check.difference_rad * check.difference_rad - check.expected_sd_rad * check.expected_sd_rad);
  check.systematic_rad = std::sqrt(s2);
  const Eigen::VectorXd u = ca / var_all;
  full.covariance.noalias() += s2 * u * u.transpose();
  check.done = true;
  return check;
}

}  // namespace areomap::ground
