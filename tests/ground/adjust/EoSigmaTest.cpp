// The a-posteriori EO sigmas of every adjustment path (fast, dense SVD, Ceres) against the scatter of the
// EO over many noise seeds of one scene (the a-priori EO and the truth fixed, only the image noise drawn
// anew), and the SVD path's own covariance from its full normal matrix against the reduced camera system's.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "firmware_core/adjust/EoCovariance.hpp"
#include "firmware_core/adjust/FastAdjuster.hpp"
#include "ground/adjust/IntegratedAdjuster.hpp"
#include "tests/firmware_core/adjust/SyntheticPanorama.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

Network g_sigma_exact;  // the scene with noise-free observations
Network g_sigma_net;    // one noise seed's network
Network g_solution;  // a copy for the second and third paths
FastAdjuster g_sigma_fast;

constexpr int kSigmaSeeds = 30;
const char* const kComponents[6] = {"x", "y", "z", "rot_x", "rot_y", "rot_z"};

// A small scene: the dense SVD is O(n^3) in the unknowns.
test::PanoramaConfig smallScene(int azimuths, int tiers, uint32_t seed) {
  test::PanoramaConfig cfg = test::navcamConfig();
  cfg.azimuths = azimuths;
  cfg.azimuth_step_deg = 360.0 / azimuths;
  cfg.tiers = tiers;
  cfg.grid = 3;
  cfg.max_range_m = 25.0;
  cfg.seed = seed;
  return cfg;
}

// The scene with exact observations (the generator draws its noise in the same sequence with a zero
// scale, so the a-priori EO is the one of the noisy scene).
void makeExactScene(test::PanoramaConfig cfg, test::PanoramaTruth& truth) {
  const double noise_px = cfg.noise_px;
  cfg.noise_px = 0.0;
  test::makePanorama(cfg, g_sigma_exact, truth);
  for (int32_t k = 0; k < g_sigma_exact.observationCount(); ++k)
    g_sigma_exact.observation(k).sigma_px = noise_px;
}

// g_sigma_net = the exact scene with Gaussian noise of each observation's sigma, from the a-priori EO.
void drawNoise(uint32_t seed) {
  test::drawImageNoise(g_sigma_exact, seed, g_sigma_net);
}

// Per path: every seed's EO (centre, rotation vector about the truth in the camera frame) and its sigmas.
struct Samples {
  std::string path;
  std::vector<std::vector<Vec6>> eo;     // [seed][image]
  std::vector<std::vector<Vec6>> sigma;  // [seed][image]
};

void record(const Network& net, const test::PanoramaTruth& truth, Samples& s) {
  std::vector<Vec6> eo(net.imageCount()), sigma(net.imageCount());
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    eo[i].head<3>() = net.image(i).centre_m - truth.centres[i];
    eo[i].tail<3>() = rotationVector(net.image(i).m * truth.rotations[i].transpose());
    sigma[i] = net.image(i).sigma;
  }
  s.eo.push_back(eo);
  s.sigma.push_back(sigma);
}

// Per component: sqrt(sum over images of the EO's variance over the seeds / sum of the mean predicted
// variance), i.e. the scatter over the predicted sigma, pooled over the images.
Vec6 scatterOverSigma(const Samples& s) {
  const int images = static_cast<int>(s.eo[0].size());
  const int n = static_cast<int>(s.eo.size());
  Vec6 scatter = Vec6::Zero(), predicted = Vec6::Zero();
  for (int i = 0; i < images; ++i) {
    Vec6 mean = Vec6::Zero();
    for (int k = 0; k < n; ++k) mean += s.eo[k][i];
    mean /= n;
    for (int k = 0; k < n; ++k) {
      scatter += (s.eo[k][i] - mean).cwiseAbs2() / (n - 1);
      predicted += s.sigma[k][i].cwiseAbs2() / n;
    }
  }
  return (scatter.array() / predicted.array()).sqrt().matrix();
}

void checkRatios(const Samples& s) {
  const Vec6 ratio = scatterOverSigma(s);
  std::printf("  %-6s scatter / sigma over %d seeds:", s.path.c_str(), static_cast<int>(s.eo.size()));
  for (int c = 0; c < 6; ++c) std::printf(" %s %.3f", kComponents[c], ratio(c));
  std::printf("\n");
  for (int c = 0; c < 6; ++c) {
    CHECK_TRUE(ratio(c) > 0.7 && ratio(c) < 1.3);
  }
}

void monteCarlo(const test::PanoramaConfig& cfg, bool with_svd) {
  test::PanoramaTruth truth;
  makeExactScene(cfg, truth);
  Samples fast{"fast", {}, {}}, svd{"svd", {}, {}}, ceres{"ceres", {}, {}};
  for (int seed = 1; seed <= kSigmaSeeds; ++seed) {
    drawNoise(static_cast<uint32_t>(seed));
    g_solution = g_sigma_net;
    FastAdjustResult fr;
    CHECK_TRUE(ok(g_sigma_fast.adjust(g_sigma_net, test::plainFastOptions(), fr)));
    CHECK_TRUE(fr.covariance_solver == CovarianceSolver::kCholesky);
    record(g_sigma_net, truth, fast);
    if (with_svd) {
      g_sigma_net = g_solution;
      (void)ground::adjustSvd(g_sigma_net);
      record(g_sigma_net, truth, svd);
    }
    g_sigma_net = g_solution;
    const ground::IntegratedResult cr = ground::adjustCeres(g_sigma_net);
    CHECK_TRUE(cr.sigma0 > 0.5 && cr.sigma0 < 1.5);
    record(g_sigma_net, truth, ceres);
  }
  std::printf("\n  %d images, %d points, %d seeds\n", g_sigma_exact.imageCount(), g_sigma_exact.pointCount(),
              kSigmaSeeds);
  checkRatios(fast);
  if (with_svd) checkRatios(svd);
  checkRatios(ceres);
}

}  // namespace

TEST_GROUP(EoSigmas){};

TEST(EoSigmas, EveryPathMatchesTheScatterOverNoiseSeeds) {
  monteCarlo(smallScene(6, 2, 3), true);
}

TEST(EoSigmas, MatchTheScatterOnAWiderRingWithASingleImage) {
  test::PanoramaConfig cfg = smallScene(10, 2, 11);
  cfg.single_image = true;
  cfg.baseline_m = 0.3;
  cfg.f_px = 900.0;
  monteCarlo(cfg, false);
}

TEST(EoSigmas, FullNormalMatrixAgreesWithTheReducedCameraSystem) {
  test::PanoramaTruth truth;
  makeExactScene(smallScene(6, 2, 5), truth);
  drawNoise(1);
  (void)ground::adjustSvd(g_sigma_net);  // its own covariance, from the full normal matrix
  g_solution = g_sigma_net;
  FastAdjustResult fr;
  CHECK_TRUE(ok(g_sigma_fast.precisionOf(g_solution, fr)));  // the reduced camera system at the same solution
  const double worst = test::largestCovarianceDifference(g_sigma_net, g_solution);
  std::printf(
      "\n  largest covariance difference svd - reduced camera system: %.2e (relative to sigma_r sigma_c)\n",
      worst);
  CHECK_TRUE(worst < 1e-6);
  CHECK_TRUE(g_sigma_net.image(0).sigma.minCoeff() > 0.0);
}
