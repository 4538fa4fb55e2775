#include "ground/ties/HoldOutCheck.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include <Eigen/Dense>

#include "firmware_core/adjust/FastAdjuster.hpp"
#include "firmware_core/camera/Photogrammetric.hpp"

namespace areomap {
namespace {

// Unknowns of a pair's relative orientation that its own ties determine (right rotation 3, base direction 2).
constexpr int32_t kRelativeOrientationUnknowns = 5;
constexpr int32_t kGaussNewtonSteps = 5;  // the point from its rays' intersection: converged in 2-3

// The point of `p` triangulated through the network's current cameras from the observations `use` allows,
// refined to least-squares reprojection; false when it does not triangulate.
bool triangulateReprojection(Network& net, int32_t p, Vec3& xyz) {
  if (!ok(net.triangulate(p))) return false;
  xyz = net.point(p).xyz_m;
  const NetPoint& point = net.point(p);
  for (int32_t step = 0; step < kGaussNewtonSteps; ++step) {
    Mat3 n = Mat3::Zero();
    Vec3 g = Vec3::Zero();
    for (int32_t k = 0; k < point.obs_count; ++k) {
      const NetObservation& o = net.observation(point.obs[k]);
      if (o.rejected) continue;
      const NetImage& im = net.image(o.image);
      Vec2 px;
      Mat2x3 jp;
      if (!ok(collinearity(im.io, im.centre_m, im.m, xyz, px, nullptr, nullptr, &jp))) return false;
      n.noalias() += jp.transpose() * jp;
      g.noalias() += jp.transpose() * (o.ideal_px - px);
    }
    const Vec3 d = n.ldlt().solve(g);
    if (!d.allFinite()) return false;
    xyz += d;
  }
  return true;
}

// Squared residual of every active observation of point p (by observation index) through the current
// cameras; false when the point does not triangulate.
bool pointResiduals(Network& net, int32_t p, std::vector<double>& squared) {
  Vec3 xyz;
  if (!triangulateReprojection(net, p, xyz)) return false;
  const NetPoint& point = net.point(p);
  for (int32_t k = 0; k < point.obs_count; ++k) {
    const NetObservation& o = net.observation(point.obs[k]);
    if (o.rejected) continue;
    const NetImage& im = net.image(o.image);
    Vec2 px;
    if (!ok(collinearity(im.io, im.centre_m, im.m, xyz, px))) return false;
    squared[point.obs[k]] = (o.ideal_px - px).squaredNorm();
  }
  return true;
}

struct Residuals {
  std::vector<double> apriori;    // per observation, squared px; NaN when not available
  std::vector<double> validated;  // held out
  std::vector<int32_t> points;    // the usable points, in fold order
};

int32_t activeObservations(const Network& net, int32_t p) {
  int32_t n = 0;
  for (int32_t k = 0; k < net.point(p).obs_count; ++k)
    n += net.observation(net.point(p).obs[k]).rejected ? 0 : 1;
  return n;
}

// Step 1: the a-priori and the cross-validated residuals of every usable point of `net`.
Residuals crossValidate(const Network& net, const FastAdjustOptions& options, int32_t folds) {
  Residuals r;
  const std::size_t n_obs = static_cast<std::size_t>(net.observationCount());
  r.apriori.assign(n_obs, std::nan(""));
  r.validated.assign(n_obs, std::nan(""));
  for (int32_t p = 0; p < net.pointCount(); ++p)
    if (activeObservations(net, p) >= 2) r.points.push_back(p);
  auto work = std::make_unique<Network>(net);
  work->resetToApriori();
  for (int32_t p : r.points) (void)pointResiduals(*work, p, r.apriori);
  auto adjuster = std::make_unique<FastAdjuster>();
  FastAdjustOptions fold_options = options;
  fold_options.eo_covariance = false;
  for (int32_t f = 0; f < folds; ++f) {
    *work = net;
    work->resetToApriori();
    for (std::size_t i = f; i < r.points.size(); i += folds) {
      const NetPoint& point = work->point(r.points[i]);
      for (int32_t k = 0; k < point.obs_count; ++k) work->observation(point.obs[k]).rejected = true;
    }
    int32_t failed = 0;
    (void)work->triangulateAll(failed);
    FastAdjustResult result;
    if (!ok(adjuster->adjust(*work, fold_options, result))) continue;  // no residuals for this fold
    for (std::size_t i = f; i < r.points.size(); i += folds) {
      const NetPoint& point = work->point(r.points[i]);
      for (int32_t k = 0; k < point.obs_count; ++k)
        work->observation(point.obs[k]).rejected = net.observation(point.obs[k]).rejected;
      (void)pointResiduals(*work, r.points[i], r.validated);
    }
  }
  return r;
}

// A point's RMS residual (per observation) over its available observations; NaN when none.
double pointRms(const Network& net, int32_t p, const std::vector<double>& squared) {
  double sum = 0.0;
  int32_t n = 0;
  for (int32_t k = 0; k < net.point(p).obs_count; ++k) {
    const double s = squared[net.point(p).obs[k]];
    if (std::isnan(s)) continue;
    sum += s;
    ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : std::nan("");
}

double robustSigma(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return std::isnan(x); }), v.end());
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return 1.4826 * v[v.size() / 2];
}

int32_t pairOf(const Network& net, int32_t image) {
  return net.image(image).pair;
}

}  // namespace

int32_t minTies(const HoldOutParams& params) {
  const int32_t k = std::max(2, params.folds);
  const int32_t train = (2 * kRelativeOrientationUnknowns * k + (k - 2)) / (k - 1);  // ceil(2 u k / (k - 1))
  return std::max(train, 2 * k);
}

HoldOutResult holdOutCheck(Network& net, const FastAdjustOptions& options, const HoldOutParams& params) {
  HoldOutResult out;
  out.folds = std::max(2, params.folds);
  std::vector<int32_t> ties(static_cast<std::size_t>(net.pairCount()), 0), wrong(ties.size(), 0);
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    if (activeObservations(net, p) < 2) continue;
    std::vector<bool> seen(ties.size(), false);
    for (int32_t k = 0; k < net.point(p).obs_count; ++k) {
      const NetObservation& o = net.observation(net.point(p).obs[k]);
      if (!o.rejected) seen[pairOf(net, o.image)] = true;
    }
    for (std::size_t q = 0; q < ties.size(); ++q) ties[q] += seen[q] ? 1 : 0;
  }
  // Steps 1 and 2.
  Residuals r = crossValidate(net, options, out.folds);
  std::vector<double> rms_a, rms_v;
  for (int32_t p : r.points) {
    rms_a.push_back(pointRms(net, p, r.apriori));
    rms_v.push_back(pointRms(net, p, r.validated));
  }
  const double sigma_a = robustSigma(rms_a), sigma_v = robustSigma(rms_v);
  for (std::size_t i = 0; i < r.points.size(); ++i) {
    const bool wrong_a = std::isnan(rms_a[i]) || rms_a[i] > params.outlier_sigmas * sigma_a;
    const bool wrong_v = std::isnan(rms_v[i]) || rms_v[i] > params.outlier_sigmas * sigma_v;
    if (!(wrong_a && wrong_v)) continue;
    const NetPoint& point = net.point(r.points[i]);
    std::vector<bool> counted(ties.size(), false);
    for (int32_t k = 0; k < point.obs_count; ++k) {
      NetObservation& o = net.observation(point.obs[k]);
      if (o.rejected) continue;
      o.rejected = true;
      ++out.wrong_observations;
      const int32_t q = pairOf(net, o.image);
      if (!counted[q]) ++wrong[q];
      counted[q] = true;
    }
  }
  if (out.wrong_observations > 0) r = crossValidate(net, options, out.folds);
  // Step 3, per pair.
  const std::size_t npairs = ties.size();
  std::vector<double> sum_d(npairs, 0.0), sum_d2(npairs, 0.0), sum_a(npairs, 0.0), sum_v(npairs, 0.0);
  std::vector<int32_t> n(npairs, 0);
  for (int32_t k = 0; k < net.observationCount(); ++k) {
    const double a = r.apriori[k], v = r.validated[k];
    if (net.observation(k).rejected || std::isnan(a) || std::isnan(v)) continue;
    const int32_t q = pairOf(net, net.observation(k).image);
    sum_d[q] += a - v;
    sum_d2[q] += (a - v) * (a - v);
    sum_a[q] += a;
    sum_v[q] += v;
    ++n[q];
  }
  const int32_t needed = minTies(params);
  for (std::size_t q = 0; q < npairs; ++q) {
    PairVerdict v;
    v.pair = static_cast<int32_t>(q);
    v.ties = ties[q];
    v.wrong_ties = wrong[q];
    const int32_t good = ties[q] - wrong[q];
    char b[256];
    if (n[q] > 1) {
      const double mean = sum_d[q] / n[q];
      const double var = std::max(0.0, (sum_d2[q] - n[q] * mean * mean) / (n[q] - 1));
      v.improvement_px2 = mean;
      v.standard_error_px2 = std::sqrt(var / n[q]);
      v.apriori_rms_px = std::sqrt(sum_a[q] / n[q]);
      v.adjusted_rms_px = std::sqrt(sum_v[q] / n[q]);
    }
    if (good < needed) {
      std::snprintf(b, sizeof b, "%d good tie points, fewer than the %d that the %d-fold check needs", good,
                    needed, out.folds);
    } else if (!(v.improvement_px2 > params.significance * v.standard_error_px2)) {
      std::snprintf(
          b, sizeof b,
          "held-out tie residuals %.3f px with the adjusted cameras, %.3f px with the a-priori ones: "
          "no significant improvement",
          v.adjusted_rms_px, v.apriori_rms_px);
    } else {
      v.adjusted = true;
      std::snprintf(
          b, sizeof b,
          "held-out tie residuals %.3f px with the adjusted cameras, %.3f px with the a-priori ones",
          v.adjusted_rms_px, v.apriori_rms_px);
    }
    v.reason = b;
    out.pairs.push_back(v);
  }
  out.ran = true;
  return out;
}

int32_t keepAprioriWhereRejected(Network& net, const HoldOutResult& check) {
  int32_t back = 0;
  for (const PairVerdict& v : check.pairs) {
    if (v.adjusted || v.pair < 0 || v.pair >= net.pairCount()) continue;
    for (int32_t image : {net.pair(v.pair).left, net.pair(v.pair).right}) {
      if (image < 0) continue;
      net.image(image).centre_m = net.image(image).centre_apriori_m;
      net.image(image).m = net.image(image).m_apriori;
    }
    ++back;
  }
  if (back > 0) {
    int32_t failed = 0;
    (void)net.triangulateAll(failed);
  }
  return back;
}

}  // namespace areomap
