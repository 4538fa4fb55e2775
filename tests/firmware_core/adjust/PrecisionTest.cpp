#include <cmath>
#include <cstdio>
#include <vector>

#include "firmware_core/adjust/FastAdjuster.hpp"
#include "firmware_core/adjust/Precision.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/adjust/SyntheticPanorama.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {
Network g_pnet;
FastAdjuster g_padjuster;
}  // namespace

TEST_GROUP(Precision){};

TEST(Precision, VanishesOnTrueCamerasAndExactObservations) {
  test::PanoramaConfig cfg = test::navcamConfig();
  cfg.noise_px = 0.0;
  cfg.pointing_min_px = 0.0;
  cfg.pointing_max_px = 0.0;
  test::PanoramaTruth truth;
  test::makePanorama(cfg, g_pnet, truth);
  HeapAllocationScope scope;
  const ImageDifferences m1 = precisionMethod1(g_pnet);
  const GroundDifferences m2 = precisionMethod2(g_pnet);
  const ImageDifferences m3 = precisionMethod3(g_pnet);
  const TiePointCounts counts = countTiePoints(g_pnet);
  CHECK_EQUAL(0u, scope.allocations());
  std::printf("\n  exact: m1 %.2e px (%d) m2 %.2e m (%d) m3 %.2e px (%d); intra %d inter %d\n", m1.dist, m1.count,
              m2.x + m2.y + m2.z, m2.count, m3.dist, m3.count, counts.intra, counts.inter);
  CHECK(m1.count > 1000 && m2.count > 50 && m3.count > 100);
  CHECK(m1.dist < 1e-6);
  CHECK(m2.x + m2.y + m2.z < 1e-6);
  CHECK(m3.dist < 1e-6);
  CHECK_EQUAL(g_pnet.pointCount(), counts.intra + counts.inter);
}

TEST(Precision, AdjustmentImprovesMethods2And3) {
  test::PanoramaTruth truth;
  test::makePanorama(test::navcamConfig(), g_pnet, truth);
  g_pnet.rig.sigma_gimbal_m = 1e-5;
  g_pnet.rig.sigma_base_m = 1e-5;
  const ImageDifferences m1b = precisionMethod1(g_pnet);
  const GroundDifferences m2b = precisionMethod2(g_pnet);
  const ImageDifferences m3b = precisionMethod3(g_pnet);
  FastAdjustResult r;
  CHECK(ok(g_padjuster.adjust(g_pnet, FastAdjustOptions{}, r)));
  const ImageDifferences m1a = precisionMethod1(g_pnet);
  const GroundDifferences m2a = precisionMethod2(g_pnet);
  const ImageDifferences m3a = precisionMethod3(g_pnet);
  std::printf("\n  navcam (mean abs) method 1: before x %.3f y %.3f dist %.3f px, after x %.3f y %.3f dist %.3f px\n"
              "  method 2: before x %.4f y %.4f z %.4f m, after x %.4f y %.4f z %.4f m (%d differences)\n"
              "  method 3: before x %.3f y %.3f dist %.3f px, after x %.3f y %.3f dist %.3f px (%d differences)\n",
              m1b.x, m1b.y, m1b.dist, m1a.x, m1a.y, m1a.dist, m2b.x, m2b.y, m2b.z, m2a.x, m2a.y, m2a.z, m2a.count,
              m3b.x, m3b.y, m3b.dist, m3a.x, m3a.y, m3a.dist, m3a.count);
  CHECK(m1a.dist < 0.5 * m1b.dist);
  CHECK(m2a.x + m2a.y + m2a.z < m2b.x + m2b.y + m2b.z);
  CHECK(m3a.dist < 0.5 * m3b.dist);
}
