// The common-vergence check (ground/adjust/CommonVergence.hpp):
//  - without systematic errors the difference t between the near half's solution and the full one has the
//    variance v = a^T (C_near - C_all) a of nested least-squares solutions: over many noise seeds mean(t^2)
//    / mean(v) is 1 (the Hausman variance), and the true common vergence error agrees with the
//    covariance's sigma;
//  - with a parallax bias of the far half of the points (their right-image x moved by -0.5 px) on a ring
//    that sees far (to 30 m, many points seen by two pairs there) the full solution's common vergence moves
//    by about a sigma, the check finds a systematic part, and the widened sigma covers the true error.
//    (On the ring of the first test, whose far points are few and seen by one pair each, the same bias
//    moves the common vergence by 0.1 urad: their depths take it.)
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "firmware_core/adjust/FastAdjuster.hpp"
#include "ground/adjust/CommonVergence.hpp"
#include "ground/adjust/FullEoCovariance.hpp"
#include "tests/firmware_core/adjust/SyntheticPanorama.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

Network g_vergence_net;
Network g_truth_net;
FastAdjuster g_vergence_fast;

test::PanoramaConfig vergenceScene(uint32_t seed) {
  test::PanoramaConfig cfg = test::navcamConfig();
  cfg.azimuths = 8;
  cfg.azimuth_step_deg = 45.0;
  cfg.tiers = 2;
  cfg.grid = 5;
  cfg.max_range_m = 25.0;
  cfg.noise_px = 0.2;
  cfg.seed = seed;
  return cfg;
}

// The true cameras in a network of the scene's shape (for commonVergenceDifference).
void setTruth(const test::PanoramaTruth& truth) {
  g_truth_net = g_vergence_net;
  for (int32_t i = 0; i < g_truth_net.imageCount(); ++i) {
    g_truth_net.image(i).centre_m = truth.centres[i];
    g_truth_net.image(i).m = truth.rotations[i];
  }
}

// Moves the right-image x of every point beyond the median point range from the gimbal by `shift_px`
// (a parallax bias of the far matches).
void biasFarParallax(double shift_px) {
  const Vec3 g = g_vergence_net.rig.gimbal_m[0];
  std::vector<double> range;
  for (int32_t p = 0; p < g_vergence_net.pointCount(); ++p)
    range.push_back((g_vergence_net.point(p).xyz_m - g).head<2>().norm());
  std::vector<double> sorted = range;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2),
                   sorted.end());
  const double median = sorted[sorted.size() / 2];
  for (int32_t k = 0; k < g_vergence_net.observationCount(); ++k) {
    NetObservation& o = g_vergence_net.observation(k);
    if (g_vergence_net.image(o.image).side == Side::kRight &&
        range[static_cast<std::size_t>(o.point)] > median)
      o.ideal_px.x() += shift_px;
  }
}

}  // namespace

TEST_GROUP(CommonVergence){};

TEST(CommonVergence, DifferenceOfTheNearHalfHasTheNestedVariance) {
  constexpr int kSeeds = 24;
  double sum_t2 = 0.0, sum_v = 0.0, sum_e2 = 0.0, sum_s2 = 0.0;
  int checked = 0;
  for (uint32_t seed = 1; seed <= kSeeds; ++seed) {
    test::PanoramaTruth truth;
    test::makePanorama(vergenceScene(seed), g_vergence_net, truth);
    FastAdjustResult r;
    CHECK_TRUE(ok(g_vergence_fast.adjust(g_vergence_net, test::plainFastOptions(), r)));
    setTruth(truth);
    ground::FullEoCovariance full = ground::fullEoCovariance(g_vergence_net);
    CHECK_TRUE(ok(full.status));
    const ground::CommonVergenceCheck c = ground::addCommonVergenceSystematic(g_vergence_net, full);
    CHECK_TRUE(c.done);
    sum_t2 += c.difference_rad * c.difference_rad;
    sum_v += c.expected_sd_rad * c.expected_sd_rad;
    const double e = ground::commonVergenceDifference(g_truth_net, g_vergence_net);
    sum_e2 += e * e / (c.sigma_rad * c.sigma_rad);
    sum_s2 += c.systematic_rad * c.systematic_rad / (c.sigma_rad * c.sigma_rad);
    ++checked;
  }
  const double ratio = std::sqrt(sum_t2 / sum_v), error = std::sqrt(sum_e2 / checked);
  std::printf(
      "\n  %d seeds: rms t / sqrt(v) %.3f, rms true error / sigma %.3f, rms systematic / sigma %.3f\n",
      checked, ratio, error, std::sqrt(sum_s2 / checked));
  CHECK_TRUE(ratio > 0.7 && ratio < 1.3);
  CHECK_TRUE(error > 0.7 && error < 1.3);
}

TEST(CommonVergence, FindsAFarParallaxBias) {
  int covered = 0, found = 0;
  double sum_e2_widened = 0.0;
  constexpr int kSeeds = 6;
  for (uint32_t seed = 1; seed <= kSeeds; ++seed) {
    test::PanoramaTruth truth;
    test::PanoramaConfig cfg = vergenceScene(100 + seed);
    cfg.azimuths = 10;
    cfg.azimuth_step_deg = 36.0;
    cfg.first_elevation_deg = 10.0;
    cfg.grid = 8;
    cfg.max_range_m = 30.0;
    test::makePanorama(cfg, g_vergence_net, truth);
    biasFarParallax(-0.5);
    int32_t failed = 0;
    (void)g_vergence_net.triangulateAll(failed);
    FastAdjustResult r;
    CHECK_TRUE(ok(g_vergence_fast.adjust(g_vergence_net, test::plainFastOptions(), r)));
    setTruth(truth);
    ground::FullEoCovariance full = ground::fullEoCovariance(g_vergence_net);
    const ground::CommonVergenceCheck c = ground::addCommonVergenceSystematic(g_vergence_net, full);
    CHECK_TRUE(c.done);
    const double e = ground::commonVergenceDifference(g_truth_net, g_vergence_net);
    const double widened = std::sqrt(c.sigma_rad * c.sigma_rad + c.systematic_rad * c.systematic_rad);
    std::printf(
        "  seed %u: true error %+.1f urad, sigma %.1f, t %+.1f (noise %.1f), systematic %.1f, widened %.1f\n",
        seed, e * 1e6, c.sigma_rad * 1e6, c.difference_rad * 1e6, c.expected_sd_rad * 1e6,
        c.systematic_rad * 1e6, widened * 1e6);
    found += c.systematic_rad > 0.0 ? 1 : 0;
    covered += std::fabs(e) < 2.0 * widened ? 1 : 0;
    sum_e2_widened += e * e / (widened * widened);
    // The widened covariance holds the systematic part along the mode.
    const Eigen::VectorXd a = ground::commonVergenceFunctional(g_vergence_net);
    DOUBLES_EQUAL(widened * widened, a.dot(full.covariance * a), 1e-6 * widened * widened);
  }
  const double rms = std::sqrt(sum_e2_widened / kSeeds);
  std::printf("  systematic part found on %d of %d seeds; rms true error / widened sigma %.2f\n", found,
              kSeeds, rms);
  CHECK_TRUE(found >= 4);  // without a bias about a third of the seeds show one (|t| > its sd)
  CHECK_EQUAL(kSeeds, covered);
  CHECK_TRUE(rms < 1.2);
}
