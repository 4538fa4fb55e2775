#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "ground/dem/KdTree.hpp"
#include "ground/dem/Kriging.hpp"
#include "ground/dem/Variogram.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dem;

namespace {

// A smooth stationary random field: a sum of cosines with random directions, wavelengths and phases.
struct RandomField {
  explicit RandomField(uint32_t seed, double min_wavelength_m, double max_wavelength_m, double amplitude_m) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const int n = 60;
    for (int i = 0; i < n; ++i) {
      const double dir = 2.0 * M_PI * u(rng);
      const double wl = min_wavelength_m * std::pow(max_wavelength_m / min_wavelength_m, u(rng));
      kx.push_back(2.0 * M_PI / wl * std::cos(dir));
      ky.push_back(2.0 * M_PI / wl * std::sin(dir));
      ph.push_back(2.0 * M_PI * u(rng));
    }
    amp = amplitude_m * std::sqrt(2.0 / n);
  }
  double operator()(double x, double y) const {
    double s = 0.0;
    for (std::size_t i = 0; i < kx.size(); ++i) s += std::cos(kx[i] * x + ky[i] * y + ph[i]);
    return amp * s;
  }
  std::vector<double> kx, ky, ph;
  double amp = 0.0;
};

// Points on an n x n lattice of 1 m at (north i, east j), elevation a i + b j, no sigma.
std::vector<DemPoint> latticePlane(int n, double a, double b) {
  std::vector<DemPoint> pts;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) pts.push_back(DemPoint{i * 1.0, j * 1.0, a * i + b * j, 0.0, -1});
  }
  return pts;
}

VariogramModel gaussianModel(double partial_sill_m2, double range_m) {
  VariogramModel m;
  m.kind = VariogramKind::kGaussian;
  m.partial_sill_m2 = partial_sill_m2;
  m.range_m = range_m;
  return m;
}

}  // namespace

TEST_GROUP(KdTree){};

TEST(KdTree, NearestMatchesBruteForce) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-50.0, 50.0);
  std::vector<double> x(5000), y(5000);
  for (std::size_t i = 0; i < x.size(); ++i) {
    x[i] = u(rng);
    y[i] = 0.1 * u(rng);  // strongly anisotropic, as far-range stereo points are
  }
  const KdTree2 tree(x, y);
  for (int q = 0; q < 200; ++q) {
    const double qx = u(rng), qy = 0.2 * u(rng);
    int32_t idx[10];
    double d2[10];
    CHECK_EQUAL(10, tree.nearest(qx, qy, 10, idx, d2));
    std::vector<double> all(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) all[i] = (x[i] - qx) * (x[i] - qx) + (y[i] - qy) * (y[i] - qy);
    std::sort(all.begin(), all.end());
    for (int j = 0; j < 10; ++j) DOUBLES_EQUAL(all[static_cast<std::size_t>(j)], d2[j], 1e-12);
  }
}

// PointBuckets (the kriging cells' fast path): queries walking along rows, each bounded by the farthest of
// the previous query's neighbours as krigeDem does. Whenever it answers, the answer is the k-d tree's bit
// for bit (indices, distances, order); on random points it answers nearly always; on a lattice with queries
// on lattice lines (exact distance ties) it declines and the tree decides; with a bound that holds fewer
// than k points it declines.
TEST(KdTree, BucketsGiveTheTreesNeighboursOrDecline) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> x, y;
  for (int i = 0; i < 20000; ++i) {  // denser towards the origin, as a rover's cloud
    const double r = 2.0 + 30.0 * u(rng) * u(rng), a = 1.5 * u(rng);
    x.push_back(r * std::cos(a));
    y.push_back(r * std::sin(a));
  }
  std::vector<double> lx, ly;
  for (int i = 0; i < 60; ++i) {
    for (int j = 0; j < 60; ++j) {
      lx.push_back(0.004 * i);
      ly.push_back(0.004 * j);
    }
  }
  struct Case {
    const std::vector<double>& x;
    const std::vector<double>& y;
    double row_step, col_step, n0, e0;
    int rows, cols, k;
  };
  const Case cases[] = {{x, y, 0.37, 0.05, 1.0, 0.5, 60, 200, 16},
                        {x, y, 0.71, 0.11, 3.0, 0.0, 30, 150, 5},
                        {lx, ly, 0.008, 0.004, 0.02, 0.0, 25, 60, 16}};
  for (const Case& c : cases) {
    const KdTree2 tree(c.x, c.y);
    const PointBuckets buckets(c.x, c.y);
    long long answered = 0, queries = 0;
    for (int row = 0; row < c.rows; ++row) {
      int32_t idx[kMaxNeighbours], tidx[kMaxNeighbours];
      double d2[kMaxNeighbours], td2[kMaxNeighbours];
      int f = 0;
      for (int col = 0; col < c.cols; ++col) {
        const double qn = c.n0 + c.row_step * row, qe = c.e0 + c.col_step * col;
        const int tf = tree.nearest(qn, qe, c.k, tidx, td2);
        if (f == c.k) {
          double bound = 0.0;
          for (int i = 0; i < f; ++i)
            bound = std::max(
                bound, (c.x[idx[i]] - qn) * (c.x[idx[i]] - qn) + (c.y[idx[i]] - qe) * (c.y[idx[i]] - qe));
          ++queries;
          const int bf = buckets.nearestWithin(qn, qe, c.k, bound, idx, d2);
          if (bf >= 0) {
            ++answered;
            CHECK_EQUAL(tf, bf);
            for (int i = 0; i < bf; ++i) {
              CHECK_EQUAL(tidx[i], idx[i]);
              CHECK(td2[i] == d2[i]);
            }
          }
          // A bound below the k-th distance holds fewer than k points.
          CHECK_EQUAL(-1, buckets.nearestWithin(qn, qe, c.k, 0.999 * td2[c.k - 1], idx, d2));
        }
        f = tf;
        std::copy(tidx, tidx + tf, idx);
      }
    }
    std::printf("\n%zu points, k = %d: the buckets answered %lld of %lld queries", c.x.size(), c.k, answered,
                queries);
    if (&c.x == &x) {
      CHECK(answered > 0.95 * queries);
    } else {
      CHECK(answered < 0.5 * queries);
    }
  }
  // A point that is not finite: no buckets, every query declines (the tree decides, as before).
  x[7] = std::nan("");
  const PointBuckets broken(x, y);
  int32_t idx[4];
  double d2[4];
  CHECK_EQUAL(-1, broken.nearestWithin(5.0, 5.0, 4, 100.0, idx, d2));
}

TEST_GROUP(Variogram){};

TEST(Variogram, FitRecoversModelOfExactData) {
  for (VariogramKind kind : {VariogramKind::kSpherical, VariogramKind::kExponential, VariogramKind::kGaussian}) {
    VariogramModel truth;
    truth.kind = kind;
    truth.nugget_m2 = 0.01;
    truth.partial_sill_m2 = 0.2;
    truth.range_m = 12.0;
    ExperimentalVariogram ev;
    for (int i = 1; i <= 25; ++i) {
      ev.lag_m.push_back(i * 1.0);
      ev.gamma_m2.push_back(truth.gamma(i * 1.0));
      ev.pairs.push_back(1000);
    }
    const VariogramModel m = fitVariogram(ev);
    std::printf("\n%s: fitted %s nugget %.4f psill %.4f range %.2f", variogramName(kind), variogramName(m.kind),
                m.nugget_m2, m.partial_sill_m2, m.range_m);
    CHECK(m.kind == kind);
    DOUBLES_EQUAL(12.0, m.range_m, 12.0 * 0.05);  // the range grid is 6 % apart
    DOUBLES_EQUAL(0.2, m.partial_sill_m2, 0.02);
  }
}

// The noise-free (signal) variogram of a cloud whose noise varies 40x across it, as a site's binned cloud
// does from near to far range: a precise part (0.5 mm) and a four times larger noisy part (20 mm, its noise
// told 15 % low, as any noise model is off somewhat), 1 % gross errors in both. The robust estimate with the
// pairs' noise must give the precise part's own noise-free semivariance at every lag (the same estimator on
// the true heights of those points), which is 1/300 of the noisy part's noise at 5 cm; the plain median over
// all pairs (the estimator before) is 5x too large there, made by the noisy part's misfit.
TEST(Variogram, SignalFromPairsOfMixedPrecision) {
  const RandomField field(3, 0.3, 3.0, 0.005);
  std::mt19937 rng(9);
  std::normal_distribution<double> unit(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> x, y, z, told_sd, xp, yp, zp;
  for (int i = 0; i < 250; ++i) {
    for (int j = 0; j < 50; ++j) {
      const double n = i * 0.02, e = j * 0.02, sd = n < 1.0 ? 0.0005 : 0.02;
      x.push_back(n);
      y.push_back(e);
      z.push_back(field(n, e) + sd * unit(rng) + (u(rng) < 0.01 ? 0.2 * unit(rng) : 0.0));
      told_sd.push_back(n < 1.0 ? sd : 0.85 * sd);
      if (n < 1.0) {
        xp.push_back(n);
        yp.push_back(e);
        zp.push_back(field(n, e));
      }
    }
  }
  const double max_lag = 0.3;
  const auto no_noise = [](std::size_t, std::size_t) { return 0.0; };
  const ExperimentalVariogram truth =
      experimentalVariogram(xp, yp, zp, max_lag, 15, 2000000, 1, no_noise, true);
  const ExperimentalVariogram ev = experimentalVariogram(
      x, y, z, max_lag, 15, 2000000, 1,
      [&](std::size_t i, std::size_t j) { return 0.5 * (told_sd[i] * told_sd[i] + told_sd[j] * told_sd[j]); },
      true);
  CHECK_EQUAL(ev.fit_weight.size(), ev.lag_m.size());
  CHECK_EQUAL(truth.lag_m.size(), ev.lag_m.size());
  for (std::size_t b = 0; b < ev.lag_m.size(); ++b) {
    std::printf("\n  lag %.3f m: the precise part's noise-free %.3f mm^2, the whole noisy cloud's %.3f mm^2",
                ev.lag_m[b], 1e6 * truth.gamma_m2[b], 1e6 * ev.gamma_m2[b]);
    // Within the sampled points' neighbourhoods (63 neighbours: 9 cm on this lattice); beyond, both rest on
    // the sparse random subset.
    if (ev.lag_m[b] < 0.09) DOUBLES_EQUAL(truth.gamma_m2[b], ev.gamma_m2[b], 0.1 * truth.gamma_m2[b]);
  }
  // The fit leans on the precise lags (its weights are the lags' information): the signal model's
  // semivariance at 5 cm is that of the noise-free fit.
  const VariogramModel m = fitVariogram(ev), mt = fitVariogram(truth);
  std::printf("\n  fitted at 5 cm: %.3f mm^2 (noise-free fit %.3f mm^2)", 1e6 * m.gamma(0.05),
              1e6 * mt.gamma(0.05));
  DOUBLES_EQUAL(mt.gamma(0.05), m.gamma(0.05), 0.15 * mt.gamma(0.05));
}

TEST_GROUP(Kriging){};

TEST(Kriging, RandomFieldSampledSparselyHonestSigma) {
  const RandomField field(11, 6.0, 40.0, 0.5);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 60.0);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::vector<DemPoint> pts;
  for (int i = 0; i < 3000; ++i) {
    DemPoint p;
    p.north_m = u(rng);
    p.east_m = u(rng);
    p.elevation_m = field(p.north_m, p.east_m) + noise(rng);
    p.sigma_m = 0.02;
    pts.push_back(p);
  }
  areomap::DemGrid grid;
  grid.east0_m = 5.0;
  grid.north0_m = 55.0;
  grid.cell_m = 0.5;
  grid.cols = 100;
  grid.rows = 100;
  const KrigingResult r = krigeDem(pts, grid, KrigingOptions{});
  double ss = 0.0, ss_field = 0.0;
  long long n = 0, within = 0;
  for (int row = 0; row < grid.rows; ++row) {
    for (int col = 0; col < grid.cols; ++col) {
      const float z = r.elevation.at(col, row);
      if (z == r.elevation.nodata) continue;
      const double t = field(grid.northOfRow(row), grid.eastOfCol(col));
      const double e = z - t;
      ss += e * e;
      ss_field += t * t;
      ++n;
      if (std::abs(e) <= r.sigma.at(col, row)) ++within;
    }
  }
  const double rmse = std::sqrt(ss / n);
  const double frac = static_cast<double>(within) / n;
  std::printf("\nkriging 3000 pts over 60x60 m -> 100x100 cells: model %s (nugget %.5f psill %.4f range %.1f m), "
              "RMSE %.4f m (field RMS %.3f m), %.1f %% of errors within 1 sigma (LOO sigma scale %.2f), %.3f s\n",
              variogramName(r.model.kind), r.model.nugget_m2, r.model.partial_sill_m2, r.model.range_m, rmse,
              std::sqrt(ss_field / n), 100.0 * frac, r.sigma_scale, r.kriging_seconds + r.variogram_seconds);
  CHECK_EQUAL(10000, n);  // every cell is inside the cloud
  CHECK(rmse < 0.1 * std::sqrt(ss_field / n));
  CHECK(frac >= 0.5 && frac <= 0.8);
}

TEST(Kriging, ExactAtDataWithoutNoiseAndGapsStayEmpty) {
  const std::vector<DemPoint> pts = latticePlane(10, 0.3, -0.1);
  const VariogramModel lin = gaussianModel(1.0, 20.0);
  KrigingOptions o;
  o.model = &lin;
  o.max_gap_m = 1.5;
  areomap::DemGrid g;
  g.east0_m = -0.5;
  g.north0_m = 15.5;  // rows 0..5 lie north of the points (north > 9.5 + 1.5): no data
  g.cell_m = 1.0;
  g.cols = 10;
  g.rows = 16;
  const KrigingResult r = krigeDem(pts, g, o);
  // Cell centres coincide with the points: a plane is reproduced exactly.
  for (int row = 6; row < g.rows; ++row) {
    for (int col = 0; col < g.cols; ++col) {
      const double n = g.northOfRow(row), e = g.eastOfCol(col);
      DOUBLES_EQUAL(0.3 * n - 0.1 * e, r.elevation.at(col, row), 1e-3);
      CHECK(r.sigma.at(col, row) < 1e-2);
    }
  }
  for (int col = 0; col < g.cols; ++col) CHECK_EQUAL(g.nodata, r.elevation.at(col, 0));
}

// A cloud smaller than one kriging neighbourhood is still kriged: the support rule
// (KrigingOptions::min_cluster_points, default k = 16) is clamped to the cloud's size.
TEST(Kriging, CloudSmallerThanANeighbourhoodIsKriged) {
  const std::vector<DemPoint> pts = latticePlane(3, 0.1, 0.0);
  const VariogramModel model = gaussianModel(1.0, 20.0);
  KrigingOptions o;
  o.model = &model;
  areomap::DemGrid g;
  g.cell_m = 1.0;
  g.cols = g.rows = 3;
  g.east0_m = -0.5;
  g.north0_m = 2.5;
  const KrigingResult r = krigeDem(pts, g, o);
  CHECK_EQUAL(9, r.min_cluster_points);
  CHECK_EQUAL(9, r.cells_kriged);
  CHECK_EQUAL(0, r.isolated_points);
}

// The sigma of a cell between or beyond the points grows with its distance d from the nearest one as the
// variogram says: ordinary kriging is the best unbiased estimate from its neighbours, so its variance is at
// most that of the nearest point alone, 2 gamma(d), and beyond the edge of a lattice (the points all
// farther than d, on one side) at least gamma(d); it rises with d (to the steps where the k nearest
// points change). The sigma is the kriging sigma times the
// leave-one-out calibration factor (sigma_scale), which the bounds divide out.
TEST(Kriging, SigmaGrowsWithDistanceFromTheNearestPointAsTheVariogramSays) {
  std::vector<DemPoint> pts = latticePlane(10, 0.0, 0.0);
  uint32_t state = 12345u;
  for (DemPoint& p : pts) {  // white heights: a finite calibration factor
    state = state * 1664525u + 1013904223u;
    p.elevation_m = 0.3 * ((state >> 8) / 16777216.0 - 0.5);
  }
  VariogramModel model;
  model.kind = VariogramKind::kExponential;
  model.partial_sill_m2 = 1.0;
  model.range_m = 6.0;
  KrigingOptions o;
  o.model = &model;
  o.max_gap_m = 6.0;
  areomap::DemGrid g;
  g.cell_m = 0.25;
  g.east0_m = 4.5 - 0.125;  // one column through the lattice's middle (east 4.5: between two columns)
  g.north0_m = 14.0;         // north 14 down to -1: across the lattice (0..9) and 5 m beyond its edge
  g.cols = 1;
  g.rows = 60;
  const KrigingResult r = krigeDem(pts, g, o);
  CHECK(r.sigma_scale > 0.0);
  double previous = -1.0;
  int beyond = 0;
  for (int row = 0; row < g.rows; ++row) {
    const double n = g.northOfRow(row), e = g.eastOfCol(0);
    double d = 1e9;
    for (const DemPoint& p : pts) d = std::min(d, std::hypot(p.north_m - n, p.east_m - e));
    const float s = r.sigma.at(0, row);
    CHECK(s != r.sigma.nodata);
    const double var = std::pow(s / r.sigma_scale, 2);
    CHECK_TEXT(var <= 2.0 * model.gamma(d) * (1.0 + 1e-6) + 1e-9, "at most the nearest point's alone");
    if (n <= 9.0) continue;
    // Beyond the north edge (rows go south: d falls row by row).
    CHECK_TEXT(var >= model.gamma(d) * (1.0 - 1e-6), "at least gamma(d) beyond the edge");
    // The k nearest points change along the way: a step of a few tenths of a percent where they do.
    if (previous >= 0.0) CHECK_TEXT(var < previous * 1.01, "falls towards the points");
    previous = var;
    ++beyond;
  }
  CHECK(beyond >= 15);
  const auto sigmaAt = [&](double north) { return r.sigma.at(0, static_cast<int>((g.north0_m - north) / g.cell_m)); };
  CHECK(sigmaAt(13.5) > 1.2 * sigmaAt(10.0));  // 4.5 m out against 1 m out
}
