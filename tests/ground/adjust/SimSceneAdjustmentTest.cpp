// The adjustment on areomap-sim scenes: the simulator's true observations
// plus 0.3 px Gaussian noise, the network built by the library code areomap-adjust uses (ground/adjust
// DatasetNetwork), adjusted by the rover's FastAdjuster at its DEFAULT options, checked against the
// simulator's truth and against the integrated adjusters (Ceres on navcam, the dense SVD on a small tiny).
// One CTest entry per group; each makes its scene once with areomap-sim --no-images and a 10 cm terrain cell
// (the presets' rig, plan, images and check points; only the terrain grid is coarser, which keeps a scene to
// seconds: navcam at its 2 cm cell takes ~100 s on a busy 2-core machine, ~10 s at 10 cm).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "firmware_core/adjust/Constraints.hpp"
#include "firmware_core/adjust/Datum.hpp"
#include "firmware_core/adjust/FastAdjuster.hpp"
#include "firmware_core/adjust/Precision.hpp"
#include "ground/adjust/DatasetNetwork.hpp"
#include "ground/adjust/IntegratedAdjuster.hpp"
#include "ground/dataset/Dataset.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/adjust/SyntheticPanorama.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

Network g_net;
Network g_reference;
FastAdjuster g_fast;

struct Scene {
  std::string dir;
  Dataset dataset;
  ground::NetworkSource source;
  ground::NetworkTruth truth;
};

// areomap-sim ARGS --no-images into a scratch folder, read back; dir is empty when the simulator failed.
Scene makeScene(const std::string& name, const std::string& sim_args) {
  Scene s;
  const std::string dir = test::scratchDir(name) + "/sim";
  const int rc = test::runTool("areomap-sim", sim_args + " --no-images --threads 2 --out " + dir);
  if (rc != 0) {
    std::printf("areomap-sim %s failed: exit %d\n", sim_args.c_str(), rc);
    return s;
  }
  s.dir = dir;
  s.dataset = readDataset(dir);
  return s;
}

// The network of the scene's truth observations + 0.3 px noise (seed 1), a-priori EO, points triangulated.
void buildNet(Scene& s, const ground::RigChoice& choice = ground::RigChoice{}) {
  const std::vector<ImageObservation> obs = ground::noisyTruthObservations(s.dataset, 0.3, 1);
  s.source = ground::NetworkSource{};
  ground::buildNetwork(s.dataset, obs, choice, g_net, s.source);
  s.truth = ground::loadNetworkTruth(s.dataset, s.source, true);
}

TruthErrors errors(const Scene& s, const Network& net, bool aligned = true) {
  return truthErrors(net, s.truth.centres.data(), s.truth.rotations.data(), s.truth.points.data(),
                     net.rig.gimbal_m[0], aligned, 5.0);
}

double maxMisfit(const FastAdjustResult& r) {
  return std::fmax(r.max_misfit.gimbal_m, std::fmax(r.max_misfit.base_m, r.max_misfit.distance_m));
}

void printResult(const char* name, const FastAdjustResult& r, const TruthErrors& e) {
  std::printf(
      "\n  %s: %s, %s, stop %s after %d (total %d) iterations, %d factor blocks, rejected %d, rms %.4f px, "
      "sigma0 %.3f, EO vs truth %.4f px, ground %.4f m (aligned), misfit gimbal %.2e m base %.2e m\n",
      name, statusName(r.status), r.cholesky_fallback ? "PCG fallback" : "direct", stopRuleName(r.stop_rule),
      r.sweeps, r.sweeps_total, r.factor_blocks, r.rejected_observations, r.rms_px, r.sigma0, e.eo_px,
      e.ground_m, r.max_misfit.gimbal_m, r.max_misfit.base_m);
}

// The integrated adjusters start from the a-priori EO with the fast adjuster's rejection flags.
void restartFromApriori() {
  test::restartFromApriori(g_net, g_reference);
}

struct Difference {
  double eo_px = 0.0;
  double ground_m = 0.0;
};

Difference largestDifference(const Network& a, const Network& b) {
  Difference d;
  for (int i = 0; i < a.imageCount(); ++i) {
    d.eo_px =
        std::fmax(d.eo_px, eoPixelEquivalent(a.image(i).io.f_px, a.image(i).centre_m - b.image(i).centre_m,
                                             rotationAngle(a.image(i).m, b.image(i).m), 5.0));
  }
  for (int p = 0; p < a.pointCount(); ++p) {
    if (a.point(p).solvable && b.point(p).solvable) {
      d.ground_m = std::fmax(d.ground_m, (a.point(p).xyz_m - b.point(p).xyz_m).norm());
    }
  }
  return d;
}

// A scene made and its network built; FAILs when the simulator failed.
Scene sceneWithNetwork(const std::string& name, const std::string& sim_args) {
  Scene s = makeScene(name, sim_args);
  if (s.dir.empty()) FAIL(("no scene: areomap-sim " + sim_args).c_str());
  buildNet(s);
  return s;
}

Scene& navcam() {
  static Scene s =
      makeScene("sim-adjust-navcam", "--preset navcam --seed 1 --cell-m 0.1 --pointing-error-px 3 15");
  return s;
}

}  // namespace

TEST_GROUP(SimNavcamAdjustment){void setup() override{if (navcam().dir.empty()) FAIL("no navcam scene");
buildNet(navcam());
}
}
;

TEST(SimNavcamAdjustment, MeetsTheIssueBounds) {
  Scene& s = navcam();
  CHECK(s.truth.available);
  const TruthErrors before = errors(s, g_net);
  const ImageDifferences m1_before = precisionMethod1(g_net);
  const GroundDifferences m2_before = precisionMethod2(g_net);
  const ImageDifferences m3_before = precisionMethod3(g_net);
  // The rig sigmas the simulator writes, and how exactly its true models satisfy the constraints.
  Network& at_truth = g_reference;
  at_truth = g_net;
  for (int i = 0; i < at_truth.imageCount(); ++i) {
    at_truth.image(i).centre_m = s.truth.centres[i];
    at_truth.image(i).m = s.truth.rotations[i];
  }
  double truth_misfit = 0.0;
  for (int p = 0; p < at_truth.pairCount(); ++p) {
    ConstraintRows rows;
    ConstraintJacobian jac;
    ConstraintMisfit misfit;
    (void)currentPairConstraintRows(at_truth, p, rows, jac, &misfit);
    truth_misfit = std::fmax(truth_misfit, std::fmax(misfit.gimbal_m, misfit.base_m));
  }
  FastAdjustResult r;
  CHECK(ok(g_fast.adjust(g_net, FastAdjustOptions{}, r)));
  const TruthErrors after = errors(s, g_net);
  const ImageDifferences m1 = precisionMethod1(g_net);
  const GroundDifferences m2 = precisionMethod2(g_net);
  const ImageDifferences m3 = precisionMethod3(g_net);
  std::printf(
      "\n  navcam (areomap-sim): %d images, %d points, %d observations; rig sigmas %.0e / %.0e m, constraint "
      "misfit of the true models %.2e m; EO vs truth before %.3f px (aligned)\n",
      g_net.imageCount(), g_net.pointCount(), g_net.observationCount(), g_net.rig.sigma_gimbal_m,
      g_net.rig.sigma_base_m, truth_misfit, before.eo_px);
  printResult("navcam fast (defaults)", r, after);
  std::printf(
      "  method 1 dist %.4f -> %.4f px; method 2 (x,y,z) %.4f %.4f %.4f -> %.4f %.4f %.4f m; "
      "method 3 dist %.4f -> %.4f px\n",
      m1_before.dist, m1.dist, m2_before.x, m2_before.y, m2_before.z, m2.x, m2.y, m2.z, m3_before.dist,
      m3.dist);
  CHECK(!r.cholesky_fallback);
  CHECK(r.stop_rule == StopRule::kCostAndStep);
  CHECK(before.eo_px > 3.0);  // the a-priori pointing is 3-15 px off
  CHECK(r.rms_px <= 0.35);
  CHECK(after.eo_px <= 0.3);
  CHECK(maxMisfit(r) <= 1e-4);
  CHECK(truth_misfit <= 1e-6);
  CHECK(r.sigma0 > 0.8 && r.sigma0 < 1.2);
  CHECK(m1.dist < m1_before.dist);
  CHECK(m2.x + m2.y + m2.z < m2_before.x + m2_before.y + m2_before.z);
  CHECK(m3.dist < m3_before.dist);
  for (int i = 0; i < g_net.imageCount(); ++i) CHECK(g_net.image(i).sigma.allFinite());
}

TEST(SimNavcamAdjustment, AgreesWithCeresAtDefaultTolerances) {
  FastAdjustResult r;
  CHECK(ok(g_fast.adjust(g_net, FastAdjustOptions{}, r)));
  restartFromApriori();
  const ground::IntegratedResult cr = ground::adjustCeres(g_reference);
  const Difference d = largestDifference(g_net, g_reference);
  std::printf(
      "\n  navcam fast: %d iterations cost %.6f | ceres: %d iterations cost %.6f (%s)\n"
      "  largest difference fast - ceres: EO %.6f px equivalent, ground %.7f m\n",
      r.sweeps, r.cost, cr.iterations, cr.cost, cr.message.c_str(), d.eo_px, d.ground_m);
  CHECK(cr.converged);
  CHECK(d.eo_px <= 0.05);
  CHECK(d.ground_m <= 0.001);
  DOUBLES_EQUAL(cr.cost, r.cost, 1e-6 * cr.cost);
}

TEST(SimNavcamAdjustment, ConstraintsOffEndWorseAgainstTruth) {
  Scene& s = navcam();
  FastAdjustResult with;
  CHECK(ok(g_fast.adjust(g_net, FastAdjustOptions{}, with)));
  const TruthErrors e_with = errors(s, g_net);
  ground::RigChoice off;
  off.gimbal = false;
  off.base = false;
  buildNet(s, off);
  FastAdjustResult without;
  CHECK(ok(g_fast.adjust(g_net, FastAdjustOptions{}, without)));
  const TruthErrors e_without = errors(s, g_net);
  std::printf(
      "\n  navcam constraints on: EO %.4f px, ground %.4f m | off: EO %.4f px, ground %.4f m (aligned)\n",
      e_with.eo_px, e_with.ground_m, e_without.eo_px, e_without.ground_m);
  CHECK(e_without.eo_px > 2.0 * e_with.eo_px);
}

TEST(SimNavcamAdjustment, GrossOutliersAreRejected) {
  Scene& s = navcam();
  // 5 % of the observations moved by 10-50 px in a random direction.
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<bool> outlier(g_net.observationCount(), false);
  int outliers = 0;
  for (int k = 0; k < g_net.observationCount(); ++k) {
    if (unit(rng) >= 0.05) continue;
    const double size = 10.0 + 40.0 * unit(rng);
    const double angle = 2.0 * M_PI * unit(rng);
    g_net.observation(k).ideal_px += size * Vec2(std::cos(angle), std::sin(angle));
    outlier[k] = true;
    ++outliers;
  }
  int32_t failed = 0;
  (void)g_net.triangulateAll(failed);
  FastAdjustResult r;
  CHECK(ok(g_fast.adjust(g_net, FastAdjustOptions{}, r)));
  int caught = 0, false_rejections = 0;
  for (int k = 0; k < g_net.observationCount(); ++k) {
    const bool rejected = g_net.observation(k).rejected || !g_net.point(g_net.observation(k).point).solvable;
    caught += outlier[k] && rejected ? 1 : 0;
    false_rejections += !outlier[k] && g_net.observation(k).rejected ? 1 : 0;
  }
  const TruthErrors e = errors(s, g_net);
  printResult("navcam 5% outliers 10-50 px", r, e);
  std::printf(
      "  outliers %d, %d of them rejected (or their point left out), %d good observations rejected of %d\n",
      outliers, caught, false_rejections, g_net.observationCount());
  // An outlier along the epipolar line of a two-ray point is absorbed in its depth: at most a few stay.
  CHECK(caught >= (95 * outliers) / 100);
  CHECK(false_rejections <= g_net.observationCount() / 100);
  CHECK(r.rms_px <= 0.35);
  CHECK(e.eo_px <= 0.3);
}

TEST(SimNavcamAdjustment, PairWithoutTiePointsIsDegenerate) {
  const int img = g_net.pair(5).right;
  for (int k = 0; k < g_net.observationCount(); ++k) {
    if (g_net.observation(k).image == img) g_net.observation(k).rejected = true;
  }
  FastAdjustResult r;
  CHECK(Status::kDegenerate == g_fast.adjust(g_net, FastAdjustOptions{}, r));
  CHECK_EQUAL(img, r.degenerate_image);
  std::printf("\n  navcam, image %s without tie points: status %s, image %d named\n",
              navcam().source.stems[img].c_str(), statusName(r.status), r.degenerate_image);
  for (int i = 0; i < g_net.imageCount(); ++i) {
    CHECK(g_net.image(i).centre_m.allFinite());
    CHECK(g_net.image(i).m.allFinite());
  }
  for (int p = 0; p < g_net.pointCount(); ++p) CHECK(g_net.point(p).xyz_m.allFinite());
}

TEST_GROUP(SimImpAdjustment){};

TEST(SimImpAdjustment, WholeAdjustmentMakesNoHeapAllocation) {
  const Scene s = sceneWithNetwork("sim-adjust-imp", "--preset imp --seed 1 --cell-m 0.1");
  FastAdjustResult r;
  Status status = Status::kOk;
  {
    HeapAllocationScope scope;
    status = g_fast.adjust(g_net, FastAdjustOptions{}, r);
    CHECK_EQUAL(0u, scope.allocations());
  }
#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
  CHECK(heapCounterActive());  // the zero above is a count, not an absent counter (sanitizers own malloc)
#endif
  CHECK(ok(status));
  const TruthErrors e = errors(s, g_net);
  std::printf("\n  imp (areomap-sim): %d pairs, %d images, %d points, %d observations", g_net.pairCount(),
              g_net.imageCount(), g_net.pointCount(), g_net.observationCount());
  printResult("imp fast (defaults), heap allocations 0", r, e);
  CHECK(!r.cholesky_fallback);
  CHECK(r.rms_px <= 0.35);
  CHECK(maxMisfit(r) <= 1e-4);
}

TEST_GROUP(SimTinyAdjustment){};

TEST(SimTinyAdjustment, SvdAndFastAgree) {
  // A small tiny (the dense SVD is O(n^3)): 150 check points.
  const Scene s =
      sceneWithNetwork("sim-adjust-tiny", "--preset tiny --seed 2 --cell-m 0.1 --check-points 150");
  FastAdjustResult r;
  CHECK(ok(g_fast.adjust(g_net, FastAdjustOptions{}, r)));
  restartFromApriori();
  const ground::IntegratedResult sr = ground::adjustSvd(g_reference);
  const Difference d = largestDifference(g_net, g_reference);
  const TruthErrors e = errors(s, g_net);
  printResult("tiny fast (defaults)", r, e);
  std::printf(
      "  svd: %d unknowns, %d iterations, cost %.6f vs fast %.6f, %.2f s; largest difference fast - svd: EO "
      "%.6f px equivalent, ground %.7f m\n",
      sr.unknowns, sr.iterations, sr.cost, r.cost, sr.seconds, d.eo_px, d.ground_m);
  CHECK(sr.converged);
  CHECK(d.eo_px <= 0.05);
  CHECK(d.ground_m <= 0.001);
  CHECK(r.rms_px <= 0.35);
}
