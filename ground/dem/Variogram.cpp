#include "ground/dem/Variogram.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "ground/dem/KdTree.hpp"

namespace areomap::dem {

namespace {
constexpr int kNeighbourPairs = 8;     // short-lag pairs per point from the k-d tree
// With pair noise: the precise points are where the cloud is dense (near range), a minority of it, and
// only their pairs tell the surface's short-lag semivariance; each sampled point takes enough neighbours
// that they cover the lags of a few kriging neighbourhoods there, not just the nearest cell or two.
constexpr int kNoisyNeighbourPairs = 63;
constexpr int kRangeCandidates = 80;   // log-spaced ranges tried per model kind
constexpr double kMedianChi2 = 0.4549;  // median of chi^2 with 1 degree of freedom
constexpr int kMaxMedianIterations = 30;  // fixed-point steps of the precision-weighted median

// The robust semivariance of one lag from its pairs' (noise-free semivariance g_k, noise n_k): each g_k is
// (gamma + n_k) X - n_k with X = chi^2_1 / its median, whose median is gamma whatever n_k, but whose
// spread grows with gamma + n_k. So gamma is the median of the g_k weighted by their precision there,
// 1 / (gamma + n_k) (the density of each pair's g at its median): where the cloud mixes precise and noisy
// points (near and far range), the precise pairs make the estimate and the noisy ones cannot bury it.
// Starts from the plain median; fixed-point steps (the weights depend on gamma) until it moves by < 0.1 %.
double precisionWeightedMedian(std::vector<std::pair<float, float>>& v, double& information) {
  std::sort(v.begin(), v.end());
  // A pair's spread at gamma: gamma + its noise (the weight is its inverse; 1e-30 keeps it finite).
  const auto spread = [](double gamma, float n) { return std::max(gamma, 0.0) + n + 1e-30; };
  const auto weightedMedian = [&](double gamma) {
    double total = 0.0;
    for (const auto& [g, n] : v) total += 1.0 / spread(gamma, n);
    double run = 0.0;
    for (const auto& [g, n] : v) {
      run += 1.0 / spread(gamma, n);
      if (run >= 0.5 * total) return static_cast<double>(g);
    }
    return static_cast<double>(v.back().first);
  };
  double gamma = v[v.size() / 2].first;
  for (int it = 0; it < kMaxMedianIterations; ++it) {
    const double next = weightedMedian(gamma);
    const bool settled = std::fabs(next - gamma) <= 1e-3 * std::fabs(next);
    gamma = next;
    if (settled) break;
  }
  information = 0.0;
  for (const auto& [g, n] : v) information += 1.0 / (spread(gamma, n) * spread(gamma, n));
  return gamma;
}

}  // namespace

const char* variogramName(VariogramKind kind) {
  switch (kind) {
    case VariogramKind::kSpherical: return "spherical";
    case VariogramKind::kExponential: return "exponential";
    case VariogramKind::kGaussian: return "gaussian";
  }
  return "?";
}

double VariogramModel::gamma(double h) const {
  if (h <= 0.0) return 0.0;
  return nugget_m2 + partial_sill_m2 * (1.0 - correlation(h));
}

ExperimentalVariogram experimentalVariogram(
    const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& z,
    double max_lag_m, int bins, int64_t max_pairs, uint32_t seed,
    const std::function<double(std::size_t, std::size_t)>& pair_noise_m2, bool robust, const KdTree2* tree) {
  if (x.size() != y.size() || x.size() != z.size()) throw std::invalid_argument("variogram: sizes differ");
  if (bins < 1 || !(max_lag_m > 0.0)) throw std::invalid_argument("variogram: bins and max lag must be > 0");
  const std::size_t n = x.size();
  std::vector<double> sum_d(static_cast<std::size_t>(bins), 0.0), sum_g(sum_d.size(), 0.0);
  std::vector<int64_t> count(sum_d.size(), 0);
  std::vector<double> sum_noise(sum_d.size(), 0.0);
  // robust: every pair's noise-free semivariance, 1/2 dz^2 / kMedianChi2 - its noise, and that noise
  std::vector<std::vector<std::pair<float, float>>> pair_g(robust ? sum_d.size() : 0);
  const double bin_w = max_lag_m / bins;
  auto add = [&](std::size_t i, std::size_t j) {
    const double dx = x[i] - x[j], dy = y[i] - y[j];
    const double h = std::sqrt(dx * dx + dy * dy);
    if (h <= 0.0 || h >= max_lag_m) return;
    const std::size_t b = std::min(static_cast<std::size_t>(h / bin_w), sum_d.size() - 1);
    const double dz = z[i] - z[j];
    sum_d[b] += h;
    sum_g[b] += 0.5 * dz * dz;
    const double pn = pair_noise_m2 ? pair_noise_m2(i, j) : 0.0;
    if (robust)
      pair_g[b].emplace_back(static_cast<float>(0.5 * dz * dz / kMedianChi2 - pn), static_cast<float>(pn));
    sum_noise[b] += pn;
    ++count[b];
  };
  const int64_t all_pairs = static_cast<int64_t>(n) * static_cast<int64_t>(n > 0 ? n - 1 : 0) / 2;
  if (all_pairs <= max_pairs) {
    for (std::size_t i = 0; i < n; ++i) {
      for (std::size_t j = i + 1; j < n; ++j) add(i, j);
    }
  } else {
    std::mt19937 rng(seed);
    // A random subset, all its pairs: every lag.
    const std::size_t m = static_cast<std::size_t>(std::sqrt(static_cast<double>(max_pairs)));
    std::vector<std::size_t> pick(n);
    for (std::size_t i = 0; i < n; ++i) pick[i] = i;
    std::shuffle(pick.begin(), pick.end(), rng);
    pick.resize(std::min(m, n));
    for (std::size_t a = 0; a < pick.size(); ++a) {
      for (std::size_t b = a + 1; b < pick.size(); ++b) add(pick[a], pick[b]);
    }
    // Short lags: each point of a second subset with its nearest neighbours.
    KdTree2 own;
    if (tree == nullptr) {
      own = KdTree2(x, y);
      tree = &own;
    }
    std::vector<std::size_t> order(n);
    for (std::size_t i = 0; i < n; ++i) order[i] = i;
    std::shuffle(order.begin(), order.end(), rng);
    const int kn = pair_noise_m2 ? kNoisyNeighbourPairs : kNeighbourPairs;
    order.resize(std::min(n, static_cast<std::size_t>(max_pairs / (2 * kn))));
    int32_t idx[kNoisyNeighbourPairs + 1];
    double d2[kNoisyNeighbourPairs + 1];
    for (std::size_t i : order) {
      const int f = tree->nearest(x[i], y[i], kn + 1, idx, d2);
      for (int k = 0; k < f; ++k) {
        if (static_cast<std::size_t>(idx[k]) != i) add(i, static_cast<std::size_t>(idx[k]));
      }
    }
  }
  ExperimentalVariogram ev;
  for (std::size_t b = 0; b < sum_d.size(); ++b) {
    if (count[b] < 3) continue;
    ev.lag_m.push_back(sum_d[b] / count[b]);
    double g = 0.0;
    if (robust) {
      double information = 0.0;
      g = precisionWeightedMedian(pair_g[b], information);
      ev.fit_weight.push_back(information);
    } else {
      g = (sum_g[b] - sum_noise[b]) / count[b];
    }
    ev.gamma_m2.push_back(std::max(0.0, g));
    ev.pairs.push_back(count[b]);
  }
  return ev;
}

VariogramModel fitVariogram(const ExperimentalVariogram& ev, VariogramKind kind) {
  VariogramModel best;
  best.kind = kind;
  best.fit_error = 1e300;
  const std::size_t n = ev.lag_m.size();
  if (n == 0) {
    best.fit_error = 0.0;
    return best;
  }
  const double max_lag = *std::max_element(ev.lag_m.begin(), ev.lag_m.end());
  const double gmax = std::max(1e-12, *std::max_element(ev.gamma_m2.begin(), ev.gamma_m2.end()));
  std::vector<double> w(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double g = std::max(ev.gamma_m2[i], 1e-6 * gmax);
    w[i] = ev.fit_weight.size() == n ? ev.fit_weight[i] : static_cast<double>(ev.pairs[i]) / (g * g);
  }
  for (int c = 0; c < kRangeCandidates; ++c) {
    VariogramModel m;
    m.kind = kind;
    m.range_m = max_lag * 0.02 * std::pow(100.0, static_cast<double>(c) / (kRangeCandidates - 1));
    // gamma_i ~ a + b f_i, f_i = 1 - rho(h_i); a, b >= 0.
    double saa = 0, sab = 0, sbb = 0, sa = 0, sb = 0;
    std::vector<double> f(n);
    for (std::size_t i = 0; i < n; ++i) {
      f[i] = 1.0 - m.correlation(ev.lag_m[i]);
      saa += w[i];
      sab += w[i] * f[i];
      sbb += w[i] * f[i] * f[i];
      sa += w[i] * ev.gamma_m2[i];
      sb += w[i] * ev.gamma_m2[i] * f[i];
    }
    double a = 0.0, b = 0.0;
    const double det = saa * sbb - sab * sab;
    if (det > 1e-12 * saa * sbb) {
      a = (sa * sbb - sb * sab) / det;
      b = (saa * sb - sab * sa) / det;
    }
    if (a < 0.0 || b < 0.0 || !(det > 1e-12 * saa * sbb)) {
      // Boundary solutions: nugget only or partial sill only; keep the better.
      const double a_only = sa / saa;
      const double b_only = sbb > 0 ? std::max(0.0, sb / sbb) : 0.0;
      double e_a = 0, e_b = 0;
      for (std::size_t i = 0; i < n; ++i) {
        e_a += w[i] * (ev.gamma_m2[i] - a_only) * (ev.gamma_m2[i] - a_only);
        e_b += w[i] * (ev.gamma_m2[i] - b_only * f[i]) * (ev.gamma_m2[i] - b_only * f[i]);
      }
      if (e_a < e_b) {
        a = a_only;
        b = 0.0;
      } else {
        a = 0.0;
        b = b_only;
      }
    }
    m.nugget_m2 = a;
    m.partial_sill_m2 = b;
    double err = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double r = ev.gamma_m2[i] - (a + b * f[i]);
      err += w[i] * r * r;
    }
    m.fit_error = err;
    if (err < best.fit_error) best = m;
  }
  return best;
}

VariogramModel fitVariogram(const ExperimentalVariogram& ev) {
  VariogramModel best;
  best.fit_error = 1e300;
  for (VariogramKind k : {VariogramKind::kSpherical, VariogramKind::kExponential, VariogramKind::kGaussian}) {
    const VariogramModel m = fitVariogram(ev, k);
    if (m.fit_error < best.fit_error) best = m;
  }
  return best;
}

}  // namespace areomap::dem
