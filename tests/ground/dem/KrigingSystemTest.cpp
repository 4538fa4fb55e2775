// The fast per-cell kriging solve (ground/dem/KrigingSystem): its weights against an independent solve of
// the full (k+1)x(k+1) ordinary-kriging system (Eigen's full-pivoting LU), the cached factorisation (and the
// one updated from the previous neighbour set) giving the same result bit for bit as a fresh one, and
// krigeDem's DEM identical for 1 and 2 threads.
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <Eigen/Dense>

#include "ground/dem/KdTree.hpp"
#include "ground/dem/Kriging.hpp"
#include "ground/dem/KrigingSystem.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dem;

namespace {

std::vector<DemPoint> scatteredPoints(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 10.0);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<DemPoint> pts(static_cast<std::size_t>(n));
  for (DemPoint& p : pts) {
    p.north_m = u(rng);
    p.east_m = u(rng);
    p.elevation_m = 0.3 * std::sin(p.north_m / 1.7) * std::cos(p.east_m / 2.3) + noise(rng);
    p.sigma_m = 0.005 + 0.01 * u(rng) / 10.0;
  }
  return pts;
}

KdTree2 treeOf(const std::vector<DemPoint>& pts) {
  std::vector<double> xs, ys;
  for (const DemPoint& p : pts) {
    xs.push_back(p.north_m);
    ys.push_back(p.east_m);
  }
  return KdTree2(xs, ys);
}

VariogramModel testModel(VariogramKind kind, double range_m) {
  VariogramModel m;
  m.kind = kind;
  m.nugget_m2 = 1e-5;
  m.partial_sill_m2 = 0.04;
  m.range_m = range_m;
  return m;
}

constexpr VariogramKind kAllKinds[] = {VariogramKind::kSpherical, VariogramKind::kExponential,
                                       VariogramKind::kGaussian};

}  // namespace

TEST_GROUP(KrigingSystem){};

// For every kind of model: the weights and the multiplier of the Cholesky + Schur solve equal those of the
// full bordered system solved by LU, to 1e-9 (relative); a repeated neighbour set reuses the factorisation
// and gives bit-identical weights, also when the neighbours come in another order.
TEST(KrigingSystem, WeightsEqualTheFullBorderedSolve) {
  const std::vector<DemPoint> pts = scatteredPoints(400, 7);
  const KdTree2 tree = treeOf(pts);
  for (VariogramKind kind : kAllKinds) {
    const VariogramModel m = testModel(kind, 3.0);
    KrigingSystem system(pts, m, true);
    double worst = 0.0;
    for (int q = 0; q < 50; ++q) {
      const double qn = 0.37 + 0.19 * q, qe = 9.1 - 0.17 * q;
      const int k = 4 + q % 13;
      int32_t idx[kMaxNeighbours];
      double d2[kMaxNeighbours];
      const int f = tree.nearest(qn, qe, k, idx, d2);
      double w[kMaxNeighbours + 1], c[kMaxNeighbours];
      CHECK(system.solve(f, idx, d2, w, c));
      // Independent: the bordered matrix, LU with full pivoting.
      Eigen::MatrixXd a = Eigen::MatrixXd::Zero(f + 1, f + 1);
      Eigen::VectorXd b = Eigen::VectorXd::Zero(f + 1);
      for (int i = 0; i < f; ++i) {
        const DemPoint& pi = pts[static_cast<std::size_t>(idx[i])];
        for (int j = 0; j < f; ++j) {
          const DemPoint& pj = pts[static_cast<std::size_t>(idx[j])];
          a(i, j) = m.partial_sill_m2 * m.correlation(std::hypot(pi.north_m - pj.north_m, pi.east_m - pj.east_m));
        }
        a(i, i) += system.noise(pi) + 1e-9 * (m.partial_sill_m2 + m.nugget_m2);
        a(i, f) = a(f, i) = 1.0;
        b(i) = m.partial_sill_m2 * m.correlation(std::sqrt(d2[i]));
        DOUBLES_EQUAL(b(i), c[i], 1e-15);
      }
      b(f) = 1.0;
      const Eigen::VectorXd sol = a.fullPivLu().solve(b);
      for (int i = 0; i <= f; ++i) worst = std::max(worst, std::fabs(sol(i) - w[i]) / (1.0 + std::fabs(sol(i))));
      // The same set again, reversed: the cached factorisation, the same weights bit for bit.
      int32_t ridx[kMaxNeighbours];
      double rd2[kMaxNeighbours], rw[kMaxNeighbours + 1], rc[kMaxNeighbours];
      for (int i = 0; i < f; ++i) {
        ridx[i] = idx[f - 1 - i];
        rd2[i] = d2[f - 1 - i];
      }
      const long long reuses = system.reuses();
      CHECK(system.solve(f, ridx, rd2, rw, rc));
      CHECK_EQUAL(reuses + 1, system.reuses());
      for (int i = 0; i < f; ++i) CHECK(rw[i] == w[f - 1 - i]);
      CHECK(rw[f] == w[f]);
    }
    std::printf("\n%s: largest weight difference to the full LU solve %.2e\n", variogramName(kind), worst);
    CHECK(worst < 1e-9);
  }
}

// Cells along a row: each neighbour set shares most points with the one before, so the system copies their
// covariances and keeps the leading columns of the factor. The weights equal those of a fresh system (which
// computes everything) bit for bit, for every kind of model and every k, whether the set changed or not.
TEST(KrigingSystem, UpdatedFactorisationEqualsAFreshOne) {
  const std::vector<DemPoint> pts = scatteredPoints(2000, 3);
  const KdTree2 tree = treeOf(pts);
  for (VariogramKind kind : kAllKinds) {
    const VariogramModel m = testModel(kind, 2.0);
    for (const int k : {3, 16, 40}) {
      KrigingSystem walking(pts, m, true);
      for (int q = 0; q < 300; ++q) {
        const double qn = 2.0 + 0.003 * q, qe = 1.0 + 0.027 * q;
        int32_t idx[kMaxNeighbours];
        double d2[kMaxNeighbours], w[kMaxNeighbours + 1], c[kMaxNeighbours], fw[kMaxNeighbours + 1],
            fc[kMaxNeighbours];
        const int f = tree.nearest(qn, qe, k, idx, d2);
        KrigingSystem fresh(pts, m, true);
        CHECK(walking.solve(f, idx, d2, w, c));
        CHECK(fresh.solve(f, idx, d2, fw, fc));
        for (int i = 0; i <= f; ++i) CHECK(w[i] == fw[i]);
        for (int i = 0; i < f; ++i) CHECK(c[i] == fc[i]);
      }
      std::printf("\n%s, k = %d: %lld factorisations, %lld reuses\n", variogramName(kind), k,
                  walking.factorisations(), walking.reuses());
      CHECK(walking.factorisations() > 30);  // the sets did change
      CHECK(walking.reuses() > 0);
    }
  }
}

// krigeDem on 1 and on 2 threads: the same DEM and sigma, bit for bit (the rows are split between the
// threads; a cell's result does not depend on the cell solved before it).
TEST(KrigingSystem, DemIsTheSameOnOneAndTwoThreads) {
  const std::vector<DemPoint> pts = scatteredPoints(3000, 11);
  const areomap::DemGrid g = gridAround(pts, 0.05);
  KrigingOptions one;
  one.threads = 1;
  KrigingOptions two = one;
  two.threads = 2;
  const KrigingResult a = krigeDem(pts, g, one);
  const KrigingResult b = krigeDem(pts, g, two);
  CHECK_EQUAL(1, a.threads);
  CHECK_EQUAL(2, b.threads);
  CHECK(a.cells_kriged > 0.9 * g.cols * g.rows);
  CHECK_EQUAL(a.cells_kriged, b.cells_kriged);
  CHECK(a.elevation.values == b.elevation.values);
  CHECK(a.sigma.values == b.sigma.values);
  std::printf("\n%lld cells from %zu points: %lld factorisations, %lld cells reused the previous cell's (%.1f %%)\n",
              a.cells_kriged, pts.size(), a.factorisations, a.factorisation_reuses,
              100.0 * a.factorisation_reuses / std::max(1LL, a.factorisations + a.factorisation_reuses));
}
