#include <cmath>
#include <cstdio>
#include <vector>

#include "firmware_core/adjust/FastAdjuster.hpp"
#include "ground/adjust/IntegratedAdjuster.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/adjust/SyntheticPanorama.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

Network g_integrated_net;
Network g_integrated_reference;
FastAdjuster g_integrated_fast;

struct IntegratedDifference {
  double eo_px = 0.0;     // largest EO difference, pixel equivalent at 5 m
  double ground_m = 0.0;  // largest 3-D point difference
};

IntegratedDifference largestIntegratedDifference(const Network& a, const Network& b) {
  IntegratedDifference d;
  for (int i = 0; i < a.imageCount(); ++i) {
    const double px = eoPixelEquivalent(a.image(i).io.f_px, a.image(i).centre_m - b.image(i).centre_m,
                                        rotationAngle(a.image(i).m, b.image(i).m), 5.0);
    d.eo_px = std::fmax(d.eo_px, px);
  }
  for (int p = 0; p < a.pointCount(); ++p) {
    if (!a.point(p).solvable) continue;
    d.ground_m = std::fmax(d.ground_m, (a.point(p).xyz_m - b.point(p).xyz_m).norm());
  }
  return d;
}

// A smaller navcam panorama (the dense SVD is O(n^3)), exactly rigid rig with the paper's tiny sigmas.
test::PanoramaConfig smallNavcam() {
  test::PanoramaConfig cfg = test::navcamConfig();
  cfg.grid = 3;
  cfg.max_range_m = 25.0;
  return cfg;
}

void makePanoramaScene(const test::PanoramaConfig& cfg, test::PanoramaTruth& truth) {
  test::makePanorama(cfg, g_integrated_net, truth);
  g_integrated_net.rig.sigma_gimbal_m = 1e-5;
  g_integrated_net.rig.sigma_base_m = 1e-5;
}

// The integrated adjusters start again from the a-priori EO, with the fast adjuster's rejection flags.
void restartIntegratedFromApriori() {
  test::restartFromApriori(g_integrated_net, g_integrated_reference);
}

FastAdjustOptions tightFast() {
  FastAdjustOptions o;
  o.eo_step_tolerance_px = 1e-7;
  o.relative_cost_tolerance = 1e-12;
  o.max_sweeps = 2000;
  return o;
}

}  // namespace

TEST_GROUP(IntegratedAdjuster){};

TEST(IntegratedAdjuster, CeresAndFastAgree) {
  test::PanoramaTruth truth;
  makePanoramaScene(test::navcamConfig(), truth);
  FastAdjustResult fr;
  CHECK(ok(g_integrated_fast.adjust(g_integrated_net, tightFast(), fr)));
  restartIntegratedFromApriori();
  const ground::IntegratedResult cr = ground::adjustCeres(g_integrated_reference);
  const IntegratedDifference d = largestIntegratedDifference(g_integrated_net, g_integrated_reference);
  std::printf("\n  navcam fast: %d sweeps cost %.6f | ceres: %d iterations cost %.6f %.3f s (%s)\n"
              "  largest difference fast-ceres: EO %.5f px equivalent, ground %.6f m\n",
              fr.sweeps, fr.cost, cr.iterations, cr.cost, cr.seconds, cr.message.c_str(), d.eo_px, d.ground_m);
  CHECK(cr.converged);
  CHECK(d.eo_px <= 0.05);
  CHECK(d.ground_m <= 0.001);
  DOUBLES_EQUAL(cr.cost, fr.cost, 1e-6 * cr.cost);
}

TEST(IntegratedAdjuster, SvdAndFastAgree) {
  test::PanoramaTruth truth;
  makePanoramaScene(smallNavcam(), truth);
  FastAdjustResult fr;
  CHECK(ok(g_integrated_fast.adjust(g_integrated_net, tightFast(), fr)));
  restartIntegratedFromApriori();
  const ground::IntegratedResult sr = ground::adjustSvd(g_integrated_reference);
  const IntegratedDifference d = largestIntegratedDifference(g_integrated_net, g_integrated_reference);
  std::printf("\n  small navcam (%d unknowns) fast: %d sweeps cost %.6f | svd: %d iterations cost %.6f %.3f s\n"
              "  largest difference fast-svd: EO %.6f px equivalent, ground %.7f m\n",
              sr.unknowns, fr.sweeps, fr.cost, sr.iterations, sr.cost, sr.seconds, d.eo_px, d.ground_m);
  CHECK(sr.converged);
  CHECK(d.eo_px <= 0.05);
  CHECK(d.ground_m <= 0.001);
}
