#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "firmware_core/adjust/Constraints.hpp"
#include "firmware_core/adjust/FastAdjuster.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/adjust/SyntheticPanorama.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using areomap::test::PanoramaTruth;

namespace {

// Caller-owned, allocated once (several MiB each).
Network g_fast_net;
FastAdjuster g_fast_adjuster;

// The paper's "very small variances" (§3.2): the synthetic rig is exactly rigid, so 10 um sigmas.
void makeScene(const test::PanoramaConfig& config, PanoramaTruth& truth) {
  test::makePanorama(config, g_fast_net, truth);
  g_fast_net.rig.sigma_gimbal_m = 1e-5;
  g_fast_net.rig.sigma_base_m = 1e-5;
}

double maxMisfit(const FastAdjustResult& r) {
  return std::fmax(r.max_misfit.gimbal_m, std::fmax(r.max_misfit.base_m, r.max_misfit.distance_m));
}

void printFastResult(const char* name, const FastAdjustResult& r, const test::TruthError& raw,
                     const test::TruthError& aligned) {
  std::printf(
      "\n  %s: status=%s stop=%s sweeps=%d (total %d) anderson acc/rej=%d/%d rejected=%d rms=%.4f px "
      "sigma0=%.3f eo_vs_truth aligned=%.4f px raw=%.4f px ground aligned=%.5f m raw=%.5f m "
      "misfit gimbal=%.2e base=%.2e m\n",
      name, statusName(r.status), stopRuleName(r.stop_rule), r.sweeps, r.sweeps_total, r.anderson_accepted,
      r.anderson_rejected, r.rejected_observations, r.rms_px, r.sigma0, aligned.eo_px, raw.eo_px,
      aligned.ground_m, raw.ground_m, r.max_misfit.gimbal_m, r.max_misfit.base_m);
}

}  // namespace

TEST_GROUP(FastAdjuster){};

TEST(FastAdjuster, NavcamMeetsTheIssueBounds) {
  PanoramaTruth truth;
  makeScene(test::navcamConfig(), truth);
  const test::TruthError before = test::truthError(g_fast_net, truth, true);
  FastAdjustResult r;
  CHECK(ok(g_fast_adjuster.adjust(g_fast_net, FastAdjustOptions{}, r)));
  const test::TruthError raw = test::truthError(g_fast_net, truth, false);
  const test::TruthError aligned = test::truthError(g_fast_net, truth, true);
  std::printf("\n  navcam: %d images %d points %d observations; before: eo aligned %.3f px\n",
              g_fast_net.imageCount(), g_fast_net.pointCount(), g_fast_net.observationCount(), before.eo_px);
  printFastResult("navcam fast", r, raw, aligned);
  CHECK(r.stop_rule == StopRule::kCostAndStep);
  CHECK(r.rms_px <= 0.35);
  CHECK(aligned.eo_px <= 0.3);
  CHECK(maxMisfit(r) <= 1e-4);
  CHECK(before.eo_px > 3.0 * aligned.eo_px);
  // sigma0 of a correct weight model is ~1.
  CHECK(r.sigma0 > 0.8 && r.sigma0 < 1.2);
  for (int32_t i = 0; i < g_fast_net.imageCount(); ++i) {
    CHECK(g_fast_net.image(i).sigma.allFinite());
    CHECK(g_fast_net.image(i).sigma.maxCoeff() > 0.0);
  }
}

TEST(FastAdjuster, ConstraintsMakeTheNetworkRigid) {
  PanoramaTruth truth;
  makeScene(test::navcamConfig(), truth);
  FastAdjustResult with;
  CHECK(ok(g_fast_adjuster.adjust(g_fast_net, FastAdjustOptions{}, with)));
  const test::TruthError e_with = test::truthError(g_fast_net, truth, true);

  makeScene(test::navcamConfig(), truth);
  g_fast_net.rig.use_gimbal = false;
  g_fast_net.rig.use_base = false;
  FastAdjustResult without;
  FastAdjustOptions options;
  options.max_sweeps = 1000;
  CHECK(ok(g_fast_adjuster.adjust(g_fast_net, options, without)));
  const test::TruthError e_without = test::truthError(g_fast_net, truth, true);
  std::printf("\n  constraints on: eo %.4f px ground %.5f m; off: eo %.4f px ground %.5f m (aligned)\n",
              e_with.eo_px, e_with.ground_m, e_without.eo_px, e_without.ground_m);
  CHECK(e_without.eo_px > 1.5 * e_with.eo_px);
}

TEST(FastAdjuster, GrossOutliersAreRejected) {
  test::PanoramaConfig cfg = test::navcamConfig();
  cfg.outlier_fraction = 0.05;
  cfg.seed = 7;
  PanoramaTruth truth;
  makeScene(cfg, truth);
  FastAdjustResult r;
  CHECK(ok(g_fast_adjuster.adjust(g_fast_net, FastAdjustOptions{}, r)));
  int32_t outliers = 0, caught = 0, false_rejections = 0;
  for (int32_t k = 0; k < g_fast_net.observationCount(); ++k) {
    if (truth.outlier[k]) ++outliers;
    if (truth.outlier[k] && g_fast_net.observation(k).rejected) ++caught;
    if (!truth.outlier[k] && g_fast_net.observation(k).rejected) ++false_rejections;
  }
  const test::TruthError aligned = test::truthError(g_fast_net, truth, true);
  printFastResult("navcam 5% outliers", r, test::truthError(g_fast_net, truth, false), aligned);
  std::printf("  outliers %d, rejected %d of them, %d good observations rejected (of %d)\n", outliers, caught,
              false_rejections, g_fast_net.observationCount());
  // An outlier along the epipolar line of a two-ray point is absorbed in its depth and cannot be seen;
  // all others must go.
  CHECK(caught >= (9 * outliers) / 10);
  CHECK(false_rejections <= g_fast_net.observationCount() / 200);
  CHECK(r.rms_px <= 0.35);
  CHECK(aligned.eo_px <= 0.3);
}

TEST(FastAdjuster, WholeImpAdjustmentMakesNoHeapAllocation) {
  PanoramaTruth truth;
  makeScene(test::impConfig(), truth);
  FastAdjustResult r;
  Status s = Status::kOk;
  {
    HeapAllocationScope scope;
    s = g_fast_adjuster.adjust(g_fast_net, FastAdjustOptions{}, r);
    CHECK_EQUAL(0u, scope.allocations());
  }
#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
  CHECK(heapCounterActive());  // the zero above is a count, not an absent counter (sanitizers own malloc)
#endif
  CHECK(ok(s));
  printFastResult("imp fast", r, test::truthError(g_fast_net, truth, false),
                  test::truthError(g_fast_net, truth, true));
  std::printf("  imp: %d pairs %d images %d points %d observations\n", g_fast_net.pairCount(),
              g_fast_net.imageCount(), g_fast_net.pointCount(), g_fast_net.observationCount());
  CHECK(r.rms_px <= 0.35);
}

TEST(FastAdjuster, AllMethodsReachTheSameMinimum) {
  // The default (LM, RCS by block Cholesky), LM with the RCS by PCG and the paper's alternation: the same
  // cost and the same EO from the same start.
  PanoramaTruth truth;
  makeScene(test::navcamConfig(), truth);
  static Network start;  // several MiB: not on the stack
  static Network first;
  start = g_fast_net;
  const FastMethod methods[3] = {FastMethod::kSchurCholesky, FastMethod::kSchurPcg,
                                 FastMethod::kGaussSeidelAnderson};
  FastAdjustResult r[3];
  for (int32_t m = 0; m < 3; ++m) {
    g_fast_net = start;
    FastAdjustOptions o;
    o.method = methods[m];
    o.robust = false;
    CHECK(ok(g_fast_adjuster.adjust(g_fast_net, o, r[m])));
    if (m > 0) {
      double eo = 0.0;
      for (int32_t i = 0; i < g_fast_net.imageCount(); ++i) {
        eo = std::fmax(eo, eoPixelEquivalent(g_fast_net.image(i).io.f_px,
                                             g_fast_net.image(i).centre_m - first.image(i).centre_m,
                                             rotationAngle(g_fast_net.image(i).m, first.image(i).m), 5.0));
      }
      std::printf(
          "\n  %s: %d iterations, cost %.6f vs %s %d iterations cost %.6f; largest EO difference %.5f px\n",
          fastMethodName(methods[m]), r[m].sweeps, r[m].cost, fastMethodName(methods[0]), r[0].sweeps,
          r[0].cost, eo);
      DOUBLES_EQUAL(r[0].cost, r[m].cost, 1e-6 * r[0].cost);
      CHECK(eo <= 0.05);
    } else {
      first = g_fast_net;
      CHECK(!r[0].cholesky_fallback);
      CHECK(r[0].factor_blocks >= g_fast_net.pairCount());
      CHECK(r[0].stop_rule == StopRule::kCostAndStep);
    }
  }
}

TEST(FastAdjuster, PaperAlternationAsWrittenConvergesSlowly) {
  // The paper's step as written (each pair with its points fixed, then each point with the EO fixed, no
  // acceleration) from the same start as the default: every sweep lowers the cost and the EO moves towards
  // the minimum, but far more sweeps than the accelerated block Gauss-Seidel leave it short of the minimum
  // that the default reaches (shared/reference/fast-adjustment.md: plain alternation stalls).
  PanoramaTruth truth;
  makeScene(test::navcamConfig(), truth);
  static Network start;
  static Network minimum;
  start = g_fast_net;
  FastAdjustOptions o;
  o.robust = false;
  FastAdjustResult lm;
  CHECK(ok(g_fast_adjuster.adjust(g_fast_net, o, lm)));
  minimum = g_fast_net;
  const test::TruthError at_minimum = test::truthError(g_fast_net, truth, true);
  const test::TruthError before = test::truthError(start, truth, true);

  constexpr int32_t kSweeps = 200;
  static double cost[kSweeps];
  static double step[kSweeps];
  g_fast_net = start;
  o.method = FastMethod::kPaperAlternation;
  o.max_sweeps = kSweeps;
  o.cost_trace = cost;
  o.step_trace = step;
  o.trace_capacity = kSweeps;
  FastAdjustResult paper;
  CHECK(ok(g_fast_adjuster.adjust(g_fast_net, o, paper)));
  const test::TruthError after = test::truthError(g_fast_net, truth, true);
  const double from_minimum = test::largestEoDifferencePx(g_fast_net, minimum);
  int32_t rises = 0;
  for (int32_t k = 1; k < paper.sweeps; ++k) rises += cost[k] > cost[k - 1] * (1.0 + 1e-12) ? 1 : 0;
  const bool paper_sigmas = paper.sigma0 > 0.0 && g_fast_net.image(0).sigma.minCoeff() > 0.0;
  o.method = FastMethod::kGaussSeidelAnderson;
  o.max_sweeps = 1000;
  o.cost_trace = nullptr;
  o.step_trace = nullptr;
  o.trace_capacity = 0;
  g_fast_net = start;
  FastAdjustResult gs;
  CHECK(ok(g_fast_adjuster.adjust(g_fast_net, o, gs)));
  std::printf(
      "\n  paper alternation: %d sweeps (stop %s), cost %.4f vs minimum %.4f, EO vs truth %.3f -> %.3f px "
      "(minimum %.3f), largest EO distance from the minimum %.3f px, %d cost rises; gauss-seidel + "
      "Anderson: %d sweeps\n",
      paper.sweeps, stopRuleName(paper.stop_rule), paper.cost, lm.cost, before.eo_px, after.eo_px,
      at_minimum.eo_px, from_minimum, rises, gs.sweeps);
  CHECK_EQUAL(0, rises);
  CHECK(after.eo_px < 0.5 * before.eo_px);     // it does adjust
  CHECK(paper.cost > lm.cost * (1.0 + 1e-6));  // but has not reached the minimum in 200 sweeps
  CHECK(gs.sweeps < paper.sweeps);
  CHECK(paper_sigmas);
}

TEST(FastAdjuster, FactorBeyondThePoolFallsBackToPcg) {
  // 128 single images on a 10 m ring around the gimbal, all looking at it; each point near the gimbal is seen
  // by 4 random images, so the pair graph is nearly complete and its factor needs ~8000 12x12 blocks, more
  // than kMaxFactorBlocks: the adjuster says so and solves by PCG.
  g_fast_net.clear();
  g_fast_net.rig = RigConstraints{};
  g_fast_net.rig.use_base = false;
  g_fast_net.rig.gimbal_m[0] = Vec3::Zero();
  g_fast_net.rig.gimbal_set[0] = true;
  g_fast_net.rig.left_offset_m = Vec3(0.0, 0.0, 10.0);  // camera centre = gimbal + 10 m along the camera's +z
  g_fast_net.rig.sigma_gimbal_m = 1e-5;
  InteriorOrientation io;
  io.f_px = 1000.0;
  io.x0_px = 511.5;
  io.y0_px = 511.5;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.3);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<Vec3> true_c;
  std::vector<Mat3> true_m;
  for (int32_t i = 0; i < kMaxPairs; ++i) {
    const double az = 2.0 * M_PI * i / kMaxPairs;
    const double el = 0.3 * std::sin(7.0 * az);
    const Vec3 z(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                 std::sin(el));  // camera +z, outward
    const Vec3 x = Vec3(0, 0, 1).cross(z).normalized();
    Mat3 m;
    m.row(0) = x.transpose();
    m.row(1) = z.cross(x).transpose();
    m.row(2) = z.transpose();
    true_c.push_back(10.0 * z);
    true_m.push_back(m);
    const Mat3 m0 = rotationFromVector(Vec3(unit(rng), unit(rng), unit(rng)) * 0.004) * m;
    int32_t pair = 0;
    CHECK(ok(g_fast_net.addPair(0, 0, io, m0.transpose() * g_fast_net.rig.left_offset_m, m0, nullptr,
                                Vec3::Zero(), m0, pair)));
  }
  std::uniform_int_distribution<int32_t> pick(0, kMaxPairs - 1);
  for (int32_t p = 0; p < 1024; ++p) {
    const Vec3 x(unit(rng), unit(rng), unit(rng));
    int32_t point = 0;
    CHECK(ok(g_fast_net.addPoint(x, point)));
    int32_t seen[4];
    for (int32_t k = 0; k < 4; ++k) {
      int32_t img = pick(rng);
      bool again = true;
      while (again) {
        again = false;
        for (int32_t j = 0; j < k; ++j) again = again || seen[j] == img;
        if (again) img = pick(rng);
      }
      seen[k] = img;
      Vec2 q;
      CHECK(ok(collinearity(io, true_c[img], true_m[img], x, q)));
      CHECK(ok(g_fast_net.addObservation(point, img, q + Vec2(noise(rng), noise(rng)), 0.3)));
    }
    CHECK(ok(g_fast_net.triangulate(point)));
  }
  // The EO covariance of this network is 768 conjugate-gradient columns, most of the test's time under
  // emulation (qemu's soft-float): there the covariance is left out, and its PCG columns are shown on the
  // target by EoCovariance.FactorAndConjugateGradientsGiveTheSameCovariance; natively it is computed here.
  FastAdjustOptions options;
  options.eo_covariance = !test::underEmulation("the fallback's adjustment without its EO covariance");
  FastAdjustResult r;
  const Status s = g_fast_adjuster.adjust(g_fast_net, options, r);
  std::printf(
      "\n  128 fully coupled images: %s, bad image %d, fallback %s, %d LM iterations, %d CG steps, rms %.4f "
      "px, stop %s\n",
      statusName(s), r.degenerate_image, r.cholesky_fallback ? "yes" : "no", r.sweeps, r.pcg_iterations,
      r.rms_px, stopRuleName(r.stop_rule));
  CHECK(ok(s));
  CHECK(r.cholesky_fallback);
  CHECK(r.pcg_iterations > 0);
  CHECK(r.rms_px < 0.35);
  // The covariance's columns come from PCG too: the factor that does not fit the LM's pool does not fit it.
  CHECK(r.covariance_solver ==
        (options.eo_covariance ? CovarianceSolver::kPcg : CovarianceSolver::kNone));
}

TEST(FastAdjuster, PairWithoutTiePointsIsDegenerate) {
  PanoramaTruth truth;
  makeScene(test::navcamConfig(), truth);
  // Reject every observation of pair 3's left image.
  const int32_t img = g_fast_net.pair(3).left;
  for (int32_t k = 0; k < g_fast_net.observationCount(); ++k) {
    if (g_fast_net.observation(k).image == img) g_fast_net.observation(k).rejected = true;
  }
  FastAdjustResult r;
  CHECK(Status::kDegenerate == g_fast_adjuster.adjust(g_fast_net, FastAdjustOptions{}, r));
  CHECK_EQUAL(img, r.degenerate_image);
  for (int32_t i = 0; i < g_fast_net.imageCount(); ++i) {
    CHECK(g_fast_net.image(i).centre_m.allFinite());
    CHECK(g_fast_net.image(i).m.allFinite());
  }
}

TEST(FastAdjuster, PointsOnALineAreDegenerate) {
  g_fast_net.clear();
  g_fast_net.rig = RigConstraints{};
  InteriorOrientation io;
  io.f_px = 1000.0;
  io.x0_px = 511.5;
  io.y0_px = 511.5;
  const Mat3 m = (Mat3() << 0, 1, 0, 0, 0, -1, -1, 0, 0).finished();  // looking north, horizontal
  int32_t pair = 0;
  CHECK(ok(g_fast_net.addPair(0, 0, io, Vec3(0, -0.1, 0), m, &io, Vec3(0, 0.1, 0), m, pair)));
  for (int32_t k = 0; k < 10; ++k) {
    const Vec3 x(5.0 + k, 0.3 * k, 0.0);  // all on one line
    int32_t p = 0;
    CHECK(ok(g_fast_net.addPoint(x, p)));
    for (int32_t side = 0; side < 2; ++side) {
      Vec2 q;
      CHECK(ok(collinearity(io, g_fast_net.image(side).centre_m, m, x, q)));
      CHECK(ok(g_fast_net.addObservation(p, side, q, 0.3)));
    }
  }
  FastAdjustResult r;
  CHECK(Status::kDegenerate == g_fast_adjuster.adjust(g_fast_net, FastAdjustOptions{}, r));
  CHECK(r.degenerate_image >= 0);
}

TEST(FastAdjuster, CapacityIsReported) {
  g_fast_net.clear();
  InteriorOrientation io;
  io.f_px = 1000.0;
  int32_t pair = 0;
  Status s = Status::kOk;
  for (int32_t i = 0; i <= kMaxPairs && ok(s); ++i) {
    s = g_fast_net.addPair(0, 0, io, Vec3::Zero(), Mat3::Identity(), &io, Vec3::Zero(), Mat3::Identity(),
                           pair);
  }
  CHECK(Status::kCapacityExceeded == s);
  CHECK_EQUAL(kMaxPairs, g_fast_net.pairCount());
}

TEST_GROUP(Constraints){};

TEST(Constraints, JacobiansMatchNumericDerivatives) {
  PanoramaTruth truth;
  makeScene(test::navcamConfig(), truth);
  g_fast_net.rig.use_spin_centre = true;
  g_fast_net.rig.use_lr_distance = true;
  g_fast_net.rig.spin_centre_m[0] = truth.gimbal_m + Vec3(0.01, 0.02, 0.0);
  g_fast_net.rig.spin_centre_set[0] = true;
  g_fast_net.rig.left_distance_m = 0.1;
  g_fast_net.rig.right_distance_m = 0.12;
  g_fast_net.rig.lr_distance_m = 0.2;
  const NetPair& p = g_fast_net.pair(0);
  const Vec3 cl = g_fast_net.image(p.left).centre_m + Vec3(0.01, -0.02, 0.005);
  const Vec3 cr = g_fast_net.image(p.right).centre_m;
  const Mat3 ml = rotationFromVector(Vec3(0.01, 0.02, -0.01)) * g_fast_net.image(p.left).m;
  const Mat3 mr = g_fast_net.image(p.right).m;
  ConstraintRows rows;
  ConstraintJacobian jac;
  const int32_t n = pairConstraintRows(g_fast_net, 0, cl, ml, cr, mr, rows, jac);
  CHECK_EQUAL(kMaxPairConstraintRows, n);
  const double h = 1e-7;
  for (int32_t k = 0; k < 12; ++k) {
    Vec12 d = Vec12::Zero();
    d(k) = h;
    Vec3 cl2 = cl, cr2 = cr;
    Mat3 ml2 = ml, mr2 = mr;
    applyCameraUpdate(d.head<6>(), cl2, ml2);
    applyCameraUpdate(d.tail<6>(), cr2, mr2);
    ConstraintRows rows2;
    ConstraintJacobian jac2;
    (void)pairConstraintRows(g_fast_net, 0, cl2, ml2, cr2, mr2, rows2, jac2);
    const ConstraintRows numeric = (rows2 - rows) / h;
    for (int32_t i = 0; i < n; ++i) {
      // The datum prior's Jacobian is the small-angle one (identity); the exact one differs by
      // J_l^-1(phi) - I ~ [phi]x / 2, harmless for a prior that only fixes the datum.
      const double tol = i >= n - 6 ? 1e-3 + 0.6 * rows.segment<6>(n - 6).cwiseAbs().maxCoeff()
                                    : 1e-3 * std::fmax(1.0, std::fabs(jac(i, k)));
      DOUBLES_EQUAL(numeric(i), jac(i, k), tol);
    }
  }
}
