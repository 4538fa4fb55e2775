// The EO covariance (EoCovariance.hpp) from the block Cholesky factor against the same columns by
// conjugate gradients (two solvers of S^-1), and without heap allocation. Its agreement with the scatter
// of the EO over noise seeds and with the dense SVD's full normal matrix: tests/ground/adjust/EoSigmaTest.
#include <cmath>
#include <cstdio>

#include "firmware_core/adjust/EoCovariance.hpp"
#include "firmware_core/adjust/FastAdjuster.hpp"
#include "firmware_core/adjust/ReducedCameraSystem.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/adjust/SyntheticPanorama.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {
Network g_cnet;
Network g_cpcg;
FastAdjuster g_cadjuster;
AdjustWorkspace g_cws;
BlockCholesky g_ccholesky;
PcgSolver g_cpcg_solver;
EoCovariance g_ccovariance;

}  // namespace

TEST_GROUP(EoCovariance){};

TEST(EoCovariance, FactorAndConjugateGradientsGiveTheSameCovariance) {
  // Pairs and a single image; an arc of 5 x 2 overlapping pairs with a 4 x 4 tie grid per image keeps the
  // conjugate-gradient columns quick (also under ASan and user-mode emulation).
  test::PanoramaConfig cfg = test::navcamConfig();
  cfg.azimuths = 5;
  cfg.grid = 4;
  cfg.single_image = true;
  cfg.seed = 7;
  test::PanoramaTruth truth;
  test::makePanorama(cfg, g_cnet, truth);
  FastAdjustResult r;
  CHECK_TRUE(ok(g_cadjuster.adjust(g_cnet, FastAdjustOptions{}, r)));
  CHECK_TRUE(r.covariance_solver == CovarianceSolver::kCholesky);
  g_cpcg = g_cnet;
  g_cws.buildImageIndex(g_cpcg);
  CovarianceSolver used = CovarianceSolver::kNone;
  HeapAllocationScope scope;
  CHECK_TRUE(ok(g_ccovariance.compute(g_cpcg, g_cws, g_ccholesky, g_cpcg_solver, r.sigma0, used,
                                      CovarianceSolver::kPcg)));
  CHECK_EQUAL(0u, scope.allocations());
  CHECK_TRUE(used == CovarianceSolver::kPcg);
  const double worst = test::largestCovarianceDifference(g_cpcg, g_cnet);
  std::printf(
      "\n  %d pairs (the last a single image), sigma0 %.3f, left image 0 sigmas %.2e %.2e %.2e m %.2e %.2e "
      "%.2e rad; largest factor - PCG difference %.2e\n",
      g_cnet.pairCount(), r.sigma0, g_cnet.image(0).sigma(0), g_cnet.image(0).sigma(1),
      g_cnet.image(0).sigma(2), g_cnet.image(0).sigma(3), g_cnet.image(0).sigma(4), g_cnet.image(0).sigma(5),
      worst);
  // PCG's columns stop at kCovariancePcgTolerance against the stiff rig rows (1e-5 m sigmas): ~1e-6.
  CHECK_TRUE(worst < 1e-5);
  for (int32_t i = 0; i < g_cnet.imageCount(); ++i) CHECK_TRUE(g_cnet.image(i).sigma.minCoeff() > 0.0);
  const NetPair& last = g_cnet.pair(g_cnet.pairCount() - 1);
  CHECK_EQUAL(-1, last.right);
  const double unused = last.covariance.bottomRightCorner<6, 6>().norm();
  CHECK_EQUAL(0.0, unused);
}

TEST(EoCovariance, PointsEliminatedWidenTheSigmasOfPointsFixed) {
  // With the points held fixed a pair's EO looks more precise than it is; eliminating them (their
  // uncertainty carried into the cameras') widens every sigma.
  test::PanoramaTruth truth;
  test::makePanorama(test::navcamConfig(), g_cnet, truth);
  FastAdjustResult r;
  CHECK_TRUE(ok(g_cadjuster.adjust(g_cnet, FastAdjustOptions{}, r)));
  g_cws.buildImageIndex(g_cnet);
  int32_t wider = 0, compared = 0;
  for (int32_t p = 0; p < g_cnet.pairCount(); ++p) {
    const NetPair& pr = g_cnet.pair(p);
    if (pr.right < 0) continue;
    // The pair's 12x12 normal block with its points fixed (observations and constraints only).
    Mat12 n = Mat12::Zero();
    Vec12 b = Vec12::Zero();
    const int32_t images[2] = {pr.left, pr.right};
    for (int s = 0; s < 2; ++s) {
      const NetImage& im = g_cnet.image(images[s]);
      for (int32_t k = 0; k < g_cnet.observationCount(); ++k) {
        const NetObservation& o = g_cnet.observation(k);
        if (o.image != images[s] || o.rejected || !g_cnet.point(o.point).solvable) continue;
        Vec2 res;
        Mat2x6 j;
        if (!ok(observationRow(o, im, im.centre_m, im.m, g_cnet.point(o.point).xyz_m, res, &j, nullptr)))
          continue;
        n.block<6, 6>(6 * s, 6 * s) += j.transpose() * j;
      }
    }
    addPairConstraints(g_cnet, p, n, b);
    // The same sandwich with the rows that are no measurement (datum prior, held rig) taken out.
    ConstraintJacobian held;
    const int32_t rows = nonMeasurementRows(g_cnet, p, held);
    const Mat12 ninv = n.ldlt().solve(Mat12::Identity());
    const Mat12 middle = n - held.topRows(rows).transpose() * held.topRows(rows);
    const Mat12 fixed = r.sigma0 * r.sigma0 * ninv * middle * ninv;
    for (int c = 0; c < 12; ++c) {
      ++compared;
      wider += pr.covariance(c, c) >= fixed(c, c) * (1.0 - 1e-9) ? 1 : 0;
    }
  }
  std::printf("\n  %d of %d variances at least those of the points-fixed blocks\n", wider, compared);
  CHECK_EQUAL(compared, wider);
}

TEST(EoCovariance, NetworkThatIsNotRigidKeepsItsAdjustmentAndSaysSo) {
  // Without Eq. 3 and Eq. 4 only the datum prior's rotations are fixed: scale and translation are free, S
  // is singular. The adjustment stands; the covariance is refused with a status and every sigma is zero.
  test::PanoramaTruth truth;
  test::makePanorama(test::navcamConfig(), g_cnet, truth);
  g_cnet.rig.use_gimbal = false;
  g_cnet.rig.use_base = false;
  FastAdjustResult r;
  CHECK_TRUE(ok(g_cadjuster.adjust(g_cnet, FastAdjustOptions{}, r)));
  CHECK_TRUE(r.covariance_status == Status::kDegenerate);
  CHECK_TRUE(r.covariance_solver == CovarianceSolver::kNone);
  CHECK_TRUE(r.sigma0 > 0.5 && r.sigma0 < 1.5);
  for (int32_t i = 0; i < g_cnet.imageCount(); ++i) CHECK_EQUAL(0.0, g_cnet.image(i).sigma.norm());
}
