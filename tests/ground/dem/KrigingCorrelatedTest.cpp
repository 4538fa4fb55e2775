// The DEM sigma with correlated point errors (Kriging.hpp, KrigingOptions::noise_correlation_px):
//  - patchVarianceFactor / patchCorrelation against brute-force sums over the pixels of the patches;
//  - a smooth surface sampled on a pixel lattice (one point per pixel, 4 mm on the ground) with errors
//    correlated as exp(-|dx| / L) exp(-|dy| / L) (a separable AR(1) field, L = 3.8 px): with the model the
//    share of the DEM errors within 1 sigma is that of a Gaussian (~68 %); with the errors taken as
//    independent the sigma is far too small (the averaging over the neighbourhood is overstated).
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "ground/dem/KdTree.hpp"
#include "ground/dem/Kriging.hpp"
#include "ground/dem/KrigingSystem.hpp"
#include "ground/dense/LineId.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dem;

namespace {

double bruteVariance(int m, double l) {
  double s = 0.0;
  for (int a = 0; a < m * m; ++a)
    for (int b = 0; b < m * m; ++b)
      s += std::exp(-std::abs(a % m - b % m) / l) * std::exp(-std::abs(a / m - b / m) / l);
  return s / (static_cast<double>(m) * m * m * m);
}

// Correlation of the means of two m x m patches, the second shifted by (dx, dy) pixels.
double bruteCorrelation(int m, int dx, int dy, double l) {
  double s = 0.0;
  for (int a = 0; a < m * m; ++a)
    for (int b = 0; b < m * m; ++b)
      s += std::exp(-std::abs(a % m - (b % m + dx)) / l) * std::exp(-std::abs(a / m - (b / m + dy)) / l);
  return s / (static_cast<double>(m) * m * m * m) / bruteVariance(m, l);
}

struct Run {
  double within = 0.0, error_rms = 0.0, sigma_rms = 0.0;
};

// Points on an n x n lattice of `gsd` metres over a smooth surface, errors of sigma s correlated with
// length l_px (pixels); kriged onto 2 cm cells with the given model length (0: independent errors).
Run krigeCorrelated(double model_l_px) {
  const int n = 200;
  const double gsd = 0.004, s = 0.005, l_px = 3.8;
  const double q = std::exp(-1.0 / l_px), c = std::sqrt(1.0 - q * q);
  std::mt19937 rng(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> e(static_cast<std::size_t>(n) * n);
  for (double& v : e) v = normal(rng);
  for (int y = 0; y < n; ++y)  // AR(1) along rows, then along columns: separable exp correlation
    for (int x = 0; x < n; ++x) e[y * n + x] = x == 0 ? e[y * n] : q * e[y * n + x - 1] + c * e[y * n + x];
  for (int x = 0; x < n; ++x)
    for (int y = 1; y < n; ++y) e[y * n + x] = q * e[(y - 1) * n + x] + c * e[y * n + x];
  const auto surface = [](double north, double east) {
    return 0.05 * std::sin(2.1 * north + 0.3) * std::cos(1.7 * east - 0.2) + 0.02 * north;
  };
  std::vector<DemPoint> pts;
  std::vector<float> gsds;
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      DemPoint p;
      p.north_m = y * gsd;
      p.east_m = x * gsd;
      p.elevation_m = surface(p.north_m, p.east_m) + s * e[y * n + x];
      p.sigma_m = s;
      pts.push_back(p);
      gsds.push_back(static_cast<float>(gsd));
    }
  }
  areomap::DemGrid grid = gridAround(pts, 0.02);
  KrigingOptions o;
  o.noise_correlation_px = model_l_px;
  o.point_gsd_m = &gsds;
  const KrigingResult r = krigeDem(pts, grid, o);
  Run run;
  long long cells = 0, within = 0;
  double e2 = 0.0, s2 = 0.0;
  for (int row = 0; row < grid.rows; ++row) {
    for (int col = 0; col < grid.cols; ++col) {
      const double north = grid.northOfRow(row), east = grid.eastOfCol(col);
      if (north < 0.05 || east < 0.05 || north > (n - 1) * gsd - 0.05 || east > (n - 1) * gsd - 0.05)
        continue;
      const float z = r.elevation.at(col, row);
      if (z == r.elevation.nodata) continue;
      const double err = z - surface(north, east), sig = r.sigma.at(col, row);
      ++cells;
      e2 += err * err;
      s2 += sig * sig;
      if (std::fabs(err) <= sig) ++within;
    }
  }
  CHECK(cells > 1000);
  run.within = static_cast<double>(within) / static_cast<double>(cells);
  run.error_rms = std::sqrt(e2 / static_cast<double>(cells));
  run.sigma_rms = std::sqrt(s2 / static_cast<double>(cells));
  std::printf("\n  model L %.1f px (variogram %.3f s, cells %.3f s): %lld cells, error RMS %.2f mm, sigma RMS "
              "%.2f mm, %.1f %% within 1 sigma",
              model_l_px, r.variogram_seconds, r.kriging_seconds, cells, 1e3 * run.error_rms, 1e3 * run.sigma_rms, 100.0 * run.within);
  return run;
}

}  // namespace

TEST_GROUP(KrigingCorrelated){};

TEST(KrigingCorrelated, PatchFactorsMatchBruteForce) {
  for (int m : {1, 2, 5, 9}) {
    for (double l : {0.5, 3.8, 12.0}) {
      DOUBLES_EQUAL(bruteVariance(m, l), patchVarianceFactor(m, l), 1e-9);
      DOUBLES_EQUAL(bruteCorrelation(m, m, 0, l), patchCorrelation(m, 0, m, l), 1e-9);
      DOUBLES_EQUAL(bruteCorrelation(m, 2 * m, m, l), patchCorrelation(2 * m, m, m, l), 1e-9);
    }
  }
  DOUBLES_EQUAL(1.0 / 25.0, patchVarianceFactor(5, 0.0), 1e-12);  // independent: 1 / n
  DOUBLES_EQUAL(1.0, patchCorrelation(0, 0, 5, 3.8), 1e-12);
}

TEST(KrigingCorrelated, SigmaHonestWithCorrelatedErrors) {
  const Run model = krigeCorrelated(3.8);
  const Run independent = krigeCorrelated(0.0);
  std::printf("\n");
  CHECK(model.within > 0.55 && model.within < 0.80);
  CHECK(model.sigma_rms > 0.7 * model.error_rms && model.sigma_rms < 1.4 * model.error_rms);
  CHECK(independent.within < 0.5);
}

// krigeDem's sigma with correlated errors (its pair terms kept from cell to cell) against the double sum of
// Kriging.hpp written out for each cell: the weights of a fresh KrigingSystem for the cell's k nearest,
//   Var = sum_i 2 w_i g(d_i0) + w_i^2 (s_i^2 + nugget) + sum_{j<i} 2 w_i w_j (s_i s_j rho_ij - g(d_ij)),
// g the signal variogram's partial-sill part, rho of the two points' patches (0 between stereo pairs).
TEST(KrigingCorrelated, SigmaIsTheDirectDoubleSum) {
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<DemPoint> pts;
  std::vector<float> gsds;
  for (int i = 0; i < 4000; ++i) {
    DemPoint p;
    p.north_m = 3.0 * u(rng);
    p.east_m = 2.0 * u(rng);
    p.sigma_m = 0.002 + 0.004 * u(rng);
    p.elevation_m = 0.05 * std::sin(3.0 * p.north_m) * std::cos(2.0 * p.east_m) + p.sigma_m * (u(rng) - 0.5);
    p.line = areomap::dense::lineId(i % 2, static_cast<int64_t>(p.north_m * 100.0));
    pts.push_back(p);
    gsds.push_back(static_cast<float>(0.002 + 0.002 * p.north_m));
  }
  const areomap::DemGrid grid = gridAround(pts, 0.03);
  KrigingOptions o;
  o.noise_correlation_px = 3.8;
  o.point_gsd_m = &gsds;
  o.bin_cell_m = 0.01;
  o.threads = 1;
  const KrigingResult r = krigeDem(pts, grid, o);
  const VariogramModel& s = r.signal_model;
  const auto g = [&s](double h) { return s.partial_sill_m2 * (1.0 - s.correlation(h)); };
  std::vector<double> xs, ys;
  for (const DemPoint& p : pts) {
    xs.push_back(p.north_m);
    ys.push_back(p.east_m);
  }
  const KdTree2 tree(xs, ys);
  long long checked = 0;
  double worst = 0.0;
  for (int cell = 0; cell < grid.cols * grid.rows; cell += 7) {
    const int col = cell % grid.cols, row = cell / grid.cols;
    if (r.sigma.at(col, row) == r.sigma.nodata) continue;
    int32_t idx[kMaxNeighbours];
    double d2[kMaxNeighbours], w[kMaxNeighbours + 1], c[kMaxNeighbours];
    const int f = tree.nearest(grid.northOfRow(row), grid.eastOfCol(col), 16, idx, d2);
    KrigingSystem system(pts, r.model, true);
    CHECK(system.solve(f, idx, d2, w, c));
    double var = 0.0;
    for (int i = 0; i < f; ++i) {
      const DemPoint& a = pts[static_cast<std::size_t>(idx[i])];
      var += 2.0 * w[i] * g(std::sqrt(d2[i])) + w[i] * w[i] * (a.sigma_m * a.sigma_m + s.nugget_m2);
      for (int j = 0; j < i; ++j) {
        const DemPoint& b = pts[static_cast<std::size_t>(idx[j])];
        double rho = 0.0;
        if (areomap::dense::linePair(a.line) == areomap::dense::linePair(b.line)) {
          const double px =
              0.5 * (gsds[static_cast<std::size_t>(idx[i])] + gsds[static_cast<std::size_t>(idx[j])]);
          rho = patchCorrelation(std::fabs(a.north_m - b.north_m) / px, std::fabs(a.east_m - b.east_m) / px,
                                 std::max(1.0, o.bin_cell_m / px), o.noise_correlation_px);
        }
        var += 2.0 * w[i] * w[j] *
               (a.sigma_m * b.sigma_m * rho - g(std::hypot(a.north_m - b.north_m, a.east_m - b.east_m)));
      }
    }
    const double expected = std::sqrt(std::max(0.0, var));
    worst = std::max(worst, std::fabs(r.sigma.at(col, row) - expected) / expected);
    ++checked;
  }
  std::printf("\n  %lld cells: largest relative difference of the sigma to the direct double sum %.2e",
              checked, worst);
  CHECK(checked > 500);
  CHECK(worst < 1e-6);
}
