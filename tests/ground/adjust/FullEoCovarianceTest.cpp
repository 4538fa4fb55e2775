// The whole EO covariance with its blocks between pairs (ground/adjust/FullEoCovariance.hpp) against the
// scatter of the fast adjuster's EO over many noise seeds of one scene: the variance of combinations that
// span every pair (the pairs' mean vergence, random combinations), which the per-pair blocks alone cannot
// predict, and its diagonal blocks against the network's own per-pair covariance.
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "firmware_core/adjust/FastAdjuster.hpp"
#include "ground/adjust/CommonVergence.hpp"
#include "ground/adjust/FullEoCovariance.hpp"
#include "tests/firmware_core/adjust/SyntheticPanorama.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

Network g_full_exact;
Network g_full_net;
FastAdjuster g_full_fast;

constexpr int kFullSeeds = 40;
constexpr int kRandomCombinations = 8;

test::PanoramaConfig fullCovarianceScene() {
  test::PanoramaConfig cfg = test::navcamConfig();
  cfg.azimuths = 8;
  cfg.azimuth_step_deg = 45.0;
  cfg.tiers = 2;
  cfg.grid = 4;
  cfg.max_range_m = 25.0;
  cfg.seed = 7;
  return cfg;
}

// The EO error of every pair as one vector in the covariance's order (12 per pair).
Eigen::VectorXd eoErrorVector(const Network& net, const test::PanoramaTruth& truth) {
  Eigen::VectorXd e = Eigen::VectorXd::Zero(12 * net.pairCount());
  for (int32_t p = 0; p < net.pairCount(); ++p) {
    const int32_t images[2] = {net.pair(p).left, net.pair(p).right};
    for (int s = 0; s < 2; ++s) {
      const int32_t i = images[s];
      if (i < 0) continue;
      e.segment<3>(12 * p + 6 * s) = net.image(i).centre_m - truth.centres[i];
      e.segment<3>(12 * p + 6 * s + 3) = rotationVector(net.image(i).m * truth.rotations[i].transpose());
    }
  }
  return e;
}

double sampleVariance(const std::vector<double>& v) {
  double mean = 0.0;
  for (double x : v) mean += x;
  mean /= static_cast<double>(v.size());
  double s = 0.0;
  for (double x : v) s += (x - mean) * (x - mean);
  return s / static_cast<double>(v.size() - 1);
}

}  // namespace

TEST_GROUP(FullEoCovariance){};

TEST(FullEoCovariance, DiagonalBlocksAreThePairCovariances) {
  test::PanoramaTruth truth;
  test::makePanorama(fullCovarianceScene(), g_full_net, truth);
  FastAdjustResult r;
  CHECK_TRUE(ok(g_full_fast.adjust(g_full_net, test::plainFastOptions(), r)));
  const ground::FullEoCovariance full = ground::fullEoCovariance(g_full_net);
  CHECK_TRUE(ok(full.status));
  DOUBLES_EQUAL(r.sigma0, full.sigma0, 1e-9 * r.sigma0);
  double worst = 0.0;
  for (int32_t p = 0; p < g_full_net.pairCount(); ++p) {
    const Mat12 block = full.covariance.block<12, 12>(12 * p, 12 * p);
    const Mat12& own = g_full_net.pair(p).covariance;
    for (int a = 0; a < 12; ++a) {
      for (int c = 0; c < 12; ++c) {
        const double scale = std::sqrt(own(a, a) * own(c, c));
        worst = std::max(worst, std::fabs(block(a, c) - own(a, c)) / scale);
      }
    }
  }
  std::printf("\n  largest difference of a diagonal block from the pair's covariance: %.2e\n", worst);
  CHECK_TRUE(worst < 1e-9);
  // Symmetric, positive semi-definite.
  CHECK_TRUE((full.covariance - full.covariance.transpose()).cwiseAbs().maxCoeff() <
             1e-12 * full.covariance.diagonal().maxCoeff());
}

TEST(FullEoCovariance, CombinationsOverAllPairsMatchTheScatterOverNoiseSeeds) {
  test::PanoramaTruth truth;
  const test::PanoramaConfig cfg = fullCovarianceScene();
  {
    test::PanoramaConfig exact = cfg;
    exact.noise_px = 0.0;
    test::makePanorama(exact, g_full_exact, truth);
    for (int32_t k = 0; k < g_full_exact.observationCount(); ++k)
      g_full_exact.observation(k).sigma_px = cfg.noise_px;
  }
  const int32_t n = g_full_exact.pairCount();
  std::mt19937 pick(99);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<Eigen::VectorXd> combos{ground::commonVergenceFunctional(g_full_exact)};
  for (int k = 0; k < kRandomCombinations; ++k) {
    Eigen::VectorXd a(12 * n);
    for (int j = 0; j < a.size(); ++j) a(j) = gauss(pick);
    combos.push_back(a);
  }
  std::vector<std::vector<double>> values(combos.size());
  Eigen::MatrixXd predicted = Eigen::MatrixXd::Zero(12 * n, 12 * n);
  for (int seed = 1; seed <= kFullSeeds; ++seed) {
    test::drawImageNoise(g_full_exact, static_cast<uint32_t>(seed), g_full_net);
    FastAdjustResult r;
    CHECK_TRUE(ok(g_full_fast.adjust(g_full_net, test::plainFastOptions(), r)));
    const ground::FullEoCovariance full = ground::fullEoCovariance(g_full_net);
    CHECK_TRUE(ok(full.status));
    predicted += full.covariance / kFullSeeds;
    const Eigen::VectorXd e = eoErrorVector(g_full_net, truth);
    for (std::size_t c = 0; c < combos.size(); ++c) values[c].push_back(combos[c].dot(e));
  }
  // The per-pair blocks alone: what the mean vergence's variance would be with independent pairs.
  Eigen::MatrixXd blocks = Eigen::MatrixXd::Zero(12 * n, 12 * n);
  for (int32_t p = 0; p < n; ++p)
    blocks.block<12, 12>(12 * p, 12 * p) = predicted.block<12, 12>(12 * p, 12 * p);
  std::printf("\n  %d pairs, %d seeds\n", n, kFullSeeds);
  double pooled_scatter = 0.0, pooled_predicted = 0.0;
  for (std::size_t c = 0; c < combos.size(); ++c) {
    const double scatter = sampleVariance(values[c]);
    const double full_var = combos[c].dot(predicted * combos[c]);
    const double block_var = combos[c].dot(blocks * combos[c]);
    std::printf(
        "  %s: scatter %.3e, full covariance %.3e (ratio %.2f), per-pair blocks only %.3e (ratio %.2f)\n",
        c == 0 ? "mean vergence (rad^2)" : "random combination  ", scatter, full_var,
        std::sqrt(scatter / full_var), block_var, std::sqrt(scatter / block_var));
    if (c == 0) {
      // One combination over 40 seeds: its standard deviation is known to ~11 %.
      const double ratio = std::sqrt(scatter / full_var);
      CHECK_TRUE(ratio > 0.7 && ratio < 1.3);
    } else {
      pooled_scatter += scatter / full_var;
      pooled_predicted += 1.0;
    }
  }
  const double pooled = std::sqrt(pooled_scatter / pooled_predicted);
  std::printf("  random combinations pooled: scatter / sigma %.3f\n", pooled);
  CHECK_TRUE(pooled > 0.8 && pooled < 1.2);
}
