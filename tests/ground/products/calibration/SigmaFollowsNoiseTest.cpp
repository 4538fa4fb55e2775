// The DEM sigma follows the images' noise: the reduced navcam scene (SigmaCalibration.hpp) rendered at
// several sensor noise and optical blur levels that the products are not told about; each pair's matching
// noise is estimated from its own left-right disagreement (ground/dense/MatchNoise.hpp). At every level,
// in each band (2-5 m, 5-10 m), 50-80 % of the DEM's errors against the true DEM must lie within 1 sigma,
// and the estimated matching sigma must grow with the noise and with the blur.
// SigmaFollowsNoise (default suite): one pair, seed 1, three levels (noise 1.5 and 4 DN, blur 0 and 1 px).
// SigmaFollowsNoiseLong (label long, AREOMAP_LONG_TESTS=1): two pairs, seeds 1..3
// (AREOMAP_CALIBRATION_SEEDS), noise 1.5 DN at blur 0, 1 and 2 px, and 4 DN at blur 0 and 1 px. Not 4 DN with
// a 2 px blur: there the left-right estimate misses the errors both directions share and the sigma is too
// small (MatchNoise.hpp).
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "tests/ground/products/calibration/SigmaCalibration.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

// Fewer cells than this in a band: the scene does not test that band (the light scene has ~2e4 at 2-5 m).
constexpr long long kMinBandCells = 1000;

// Runs one level and counts its bands outside 50-80 % within 1 sigma; returns the pairs' mean sigma.
double runLevel(test::CalibrationScene scene, double noise_dn, double blur_px, int& failures) {
  scene.noise_dn = noise_dn;
  scene.blur_px = blur_px;
  const test::CalibrationFigures fig = test::runCalibrationScene(scene);
  char label[96];
  std::snprintf(label, sizeof label, "seed %llu, noise %.1f DN, blur %.1f px",
                static_cast<unsigned long long>(scene.seed), noise_dn, blur_px);
  test::printCalibrationRow(label, fig);
  for (const test::BandFigures& b : fig.bands) {
    if (b.filled < kMinBandCells || b.within1Sigma() < 0.5 || b.within1Sigma() > 0.8) ++failures;
  }
  double sum = 0.0;
  for (const ground::DensePairNoise& p : fig.dense_pairs) {
    if (p.match_sigma_source != "left_right") ++failures;
    sum += p.match_sigma_px;
  }
  return fig.dense_pairs.empty() ? 0.0 : sum / static_cast<double>(fig.dense_pairs.size());
}

void printHeader() {
  std::printf(
      "\n| level | match sigma per pair (source, samples) | 2-5 m: RMSE, sigma RMS, within 1 sigma | 5-10 m: "
      "RMSE, "
      "sigma RMS, within 1 sigma |\n|---|---|---|---|\n");
}

}  // namespace

TEST_GROUP(SigmaFollowsNoise){};

TEST(SigmaFollowsNoise, FiftyToEightyPercentWithinOneSigmaAtEachNoiseAndBlurLevel) {
  test::CalibrationScene scene;
  scene.pairs = 1;
  printHeader();
  int failures = 0;
  const double base = runLevel(scene, 1.5, 0.0, failures);
  const double noisy = runLevel(scene, 4.0, 0.0, failures);
  const double noisy_blurred = runLevel(scene, 4.0, 1.0, failures);
  LONGS_EQUAL_TEXT(0, failures,
                   "bands outside 50-80 % within 1 sigma (or too few cells, or a fallback sigma)");
  CHECK_TEXT(noisy > base, "the matching sigma does not grow with the image noise");
  CHECK_TEXT(noisy_blurred > noisy, "the matching sigma does not grow with the blur");
}

TEST_GROUP(SigmaFollowsNoiseLong){};

TEST(SigmaFollowsNoiseLong, FiftyToEightyPercentWithinOneSigmaAtEveryLevelOnEveryTerrain) {
  if (std::getenv("AREOMAP_LONG_TESTS") == nullptr) {
    std::printf(
        "SKIP: the sigma at several noise and blur levels runs with AREOMAP_LONG_TESTS=1 (ctest -L long)\n");
    return;
  }
  int seeds = 3;
  if (const char* s = std::getenv("AREOMAP_CALIBRATION_SEEDS")) seeds = std::max(1, std::atoi(s));
  printHeader();
  int failures = 0;
  for (int seed = 1; seed <= seeds; ++seed) {
    test::CalibrationScene scene;
    scene.seed = static_cast<uint64_t>(seed);
    for (const double noise : {1.5, 4.0}) {
      double previous = 0.0;
      for (const double blur :
           noise < 2.0 ? std::vector<double>{0.0, 1.0, 2.0} : std::vector<double>{0.0, 1.0}) {
        const double sigma = runLevel(scene, noise, blur, failures);
        if (!(sigma > previous)) ++failures;
        previous = sigma;
      }
    }
  }
  LONGS_EQUAL_TEXT(0, failures,
                   "bands outside 50-80 % within 1 sigma, or a sigma that does not grow with the blur");
}
