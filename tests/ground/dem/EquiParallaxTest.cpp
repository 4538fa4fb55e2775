#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "ground/dem/EquiParallax.hpp"
#include "ground/dem/Kriging.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dem;

namespace {

// Rolling terrain out to 60 m: elevation up, metres, of site (north, east).
double terrain(double n, double e) {
  return 0.35 * std::sin(n / 9.0 + 0.3) * std::cos(e / 13.0) + 0.25 * std::sin((n + 2.0 * e) / 17.0) +
         0.01 * n;
}

// Points of a stereo rig 1.5 m above the ground at the origin looking over a 60 degree sector: one point
// per image column (azimuth step 2/f) and row (depression atan(row/f)); range noise from the disparity
// noise along the ray (sigma_r = r^2 sigma_d / (f b)). Each row is one equi-parallax line.
// Distance along the ray from the rig (1.5 m up at the origin) in direction (dn, de, dz) to the terrain;
// -1 when it does not reach it within 90 m.
double castRay(double dn, double de, double dz) {
  const double height_m = 1.5;
  double t0 = 0.0, t1 = -1.0;  // march to the first crossing of the terrain, then bisect
  for (double t = 0.5; t < 90.0; t += 0.5) {
    if (height_m + t * dz < terrain(t * dn, t * de)) {
      t1 = t;
      break;
    }
    t0 = t;
  }
  if (t1 < 0.0) return -1.0;
  for (int it = 0; it < 30; ++it) {
    const double tm = 0.5 * (t0 + t1);
    (height_m + tm * dz < terrain(tm * dn, tm * de) ? t1 : t0) = tm;
  }
  return 0.5 * (t0 + t1);
}

// `gross` of the points get a disparity error of +-2 px (mismatches) instead of the noise.
std::vector<DemPoint> rigPoints(uint32_t seed, double gross = 0.0) {
  const double f_px = 800.0, base_m = 0.3, sigma_d_px = 0.2, height_m = 1.5;
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<DemPoint> pts;
  for (int row = 18; row <= 260; ++row) {
    const double alpha = std::atan(row / f_px);
    for (double az = -0.5; az <= 0.5; az += 2.0 / f_px) {
      const double dn = std::cos(alpha) * std::cos(az), de = std::cos(alpha) * std::sin(az), dz = -std::sin(alpha);
      const double t = castRay(dn, de, dz);
      if (t < 0.0) continue;
      const double sr = t * t * sigma_d_px / (f_px * base_m);
      const bool mismatch = gross > 0.0 && uniform(rng) < gross;
      const double tn = mismatch ? 1.0 / (1.0 / t + (uniform(rng) < 0.5 ? -2.0 : 2.0) / (f_px * base_m))
                                 : t + sr * unit(rng);
      if (tn <= 0.0) continue;
      DemPoint p;
      p.north_m = tn * dn;
      p.east_m = tn * de;
      p.elevation_m = height_m + tn * dz;
      p.sigma_m = sr * std::sin(alpha);
      p.line = row;
      pts.push_back(p);
    }
  }
  return pts;
}

// RMS over the points 20-55 m out of |1/measured distance - 1/true distance| * f b (the disparity error,
// px) along each point's own ray.
double disparityRms(const std::vector<DemPoint>& pts) {
  double ss = 0;
  long long n = 0;
  for (const DemPoint& p : pts) {
    const double dz = p.elevation_m - 1.5, h = std::hypot(p.north_m, p.east_m), rho = std::hypot(h, dz);
    if (h < 20.0 || h > 55.0) continue;
    const double t = castRay(p.north_m / rho, p.east_m / rho, dz / rho);
    if (t < 0.0) continue;
    const double e = (1.0 / rho - 1.0 / t) * 800.0 * 0.3;
    ss += e * e;
    ++n;
  }
  return std::sqrt(ss / std::max(1LL, n));
}

// An empty grid of `cols` x `rows` cells of `cell_m`, its north-west corner at (east0_m, north0_m).
areomap::DemGrid emptyGrid(double cell_m, double east0_m, double north0_m, int cols, int rows) {
  areomap::DemGrid g;
  g.cell_m = cell_m;
  g.east0_m = east0_m;
  g.north0_m = north0_m;
  g.cols = cols;
  g.rows = rows;
  return g;
}

}  // namespace

TEST_GROUP(EquiParallax){};

TEST(EquiParallax, BeatsKrigingBeyondTwentyMetres) {
  const std::vector<DemPoint> pts = rigPoints(21);
  areomap::DemGrid grid;
  grid.cell_m = 0.5;
  grid.east0_m = -32.0;
  grid.north0_m = 62.0;
  grid.cols = 128;
  grid.rows = 124;
  KrigingResult kr = krigeDem(pts, grid, KrigingOptions{});
  EquiParallaxOptions o;
  o.centre_up_m = 1.5;  // the rig's cameras
  areomap::DemGrid far_sigma;
  const areomap::DemGrid far = equiParallaxDem(pts, grid, o, &far_sigma);
  KrigingResult blended = kr;
  blendFarRange(blended, far, &far_sigma, o);
  double ss_k = 0, ss_e = 0, ss_b = 0;
  long long n = 0;
  for (int row = 0; row < grid.rows; ++row) {
    for (int col = 0; col < grid.cols; ++col) {
      const double nn = grid.northOfRow(row), ee = grid.eastOfCol(col);
      const double r = std::hypot(nn, ee);
      if (r < 20.0 || r > 55.0 || std::abs(std::atan2(ee, nn)) > 0.45) continue;
      const float zk = kr.elevation.at(col, row), ze = far.at(col, row);
      if (zk == grid.nodata || ze == grid.nodata) continue;
      const double t = terrain(nn, ee);
      ss_k += (zk - t) * (zk - t);
      ss_e += (ze - t) * (ze - t);
      ss_b += (blended.elevation.at(col, row) - t) * (blended.elevation.at(col, row) - t);
      ++n;
    }
  }
  const double rk = std::sqrt(ss_k / n), re = std::sqrt(ss_e / n), rb = std::sqrt(ss_b / n);
  std::printf("\nfar range 20-55 m (%zu points, %lld cells of 0.5 m): RMSE kriging alone %.4f m, "
              "equi-parallax %.4f m, blended %.4f m\n", pts.size(), n, rk, re, rb);
  CHECK(n > 2000);
  CHECK(re < rk);
  CHECK(rb < rk);
}

TEST(EquiParallax, KrigingOnlyTheCellsTheBlendKeepsGivesTheSameDem) {
  std::vector<DemPoint> pts;  // every 4th of the rig's points: a few seconds at most
  const std::vector<DemPoint> all = rigPoints(21);
  for (std::size_t i = 0; i < all.size(); i += 4) pts.push_back(all[i]);
  const areomap::DemGrid grid = emptyGrid(1.0, -32.0, 62.0, 64, 62);
  EquiParallaxOptions o;
  o.centre_up_m = 1.5;
  areomap::DemGrid far_sigma;
  const areomap::DemGrid far = equiParallaxDem(pts, grid, o, &far_sigma);
  const std::vector<uint8_t> keeps = cellsBlendKeeps(far, o);
  KrigingOptions ko;
  const KrigingResult whole = krigeDem(pts, grid, ko);
  ko.cells = &keeps;
  const KrigingResult part = krigeDem(pts, grid, ko);
  long long skipped = 0, kriged_skipped = 0;
  for (std::size_t i = 0; i < keeps.size(); ++i) {
    if (keeps[i] != 0) continue;
    ++skipped;
    kriged_skipped += whole.elevation.values[i] != grid.nodata;
    CHECK_EQUAL(grid.nodata, part.elevation.values[i]);  // not kriged
  }
  std::printf("\n%lld of %zu cells left to the far range, %lld of them kriged without the mask\n", skipped,
              keeps.size(), kriged_skipped);
  CHECK(kriged_skipped > 100);
  CHECK_EQUAL(whole.cells_kriged - kriged_skipped, part.cells_kriged);
  KrigingResult a = whole, b = part;
  blendFarRange(a, far, &far_sigma, o);
  blendFarRange(b, far, &far_sigma, o);
  for (std::size_t i = 0; i < keeps.size(); ++i) {  // bit for bit
    CHECK_EQUAL(a.elevation.values[i], b.elevation.values[i]);
    CHECK_EQUAL(a.sigma.values[i], b.sigma.values[i]);
  }
}

TEST(EquiParallax, BlendIsContinuousAtTheSeam) {
  // Constant fields: kriging 1, far 3; the blend goes 1 -> 3 linearly across [18, 22] m.
  const areomap::DemGrid g = emptyGrid(1.0, -0.5, 30.0, 1, 30);
  KrigingResult k;
  k.elevation = g;
  k.elevation.values.assign(30, 1.0f);
  k.sigma = g;
  k.sigma.values.assign(30, 0.1f);
  areomap::DemGrid far = g;
  far.values.assign(30, 3.0f);
  EquiParallaxOptions o;
  blendFarRange(k, far, nullptr, o);
  for (int row = 0; row < g.rows; ++row) {
    const double r = g.northOfRow(row);
    const double w = std::clamp((r - 18.0) / 4.0, 0.0, 1.0);
    DOUBLES_EQUAL(1.0 + 2.0 * w, k.elevation.at(0, row), 1e-6);
  }
}

TEST(EquiParallax, FitAlongRaysAveragesTheDisparityNoiseAndIgnoresMismatches) {
  // 0.2 px of independent disparity noise, 3 % mismatches of +-2 px: the fitted points, each moved along
  // its own ray, have a fraction of the raw disparity error (a +-20 column x +-3 row window holds ~280
  // points); a least-squares fit (no reweighting) lets the mismatches through.
  std::vector<DemPoint> pts;
  for (const DemPoint& p : rigPoints(5, 0.03)) {
    if (std::hypot(p.north_m, p.east_m) > 15.0) pts.push_back(p);  // the rows that reach 20-55 m
  }
  EquiParallaxOptions o;
  o.centre_up_m = 1.5;
  const double raw = disparityRms(pts), fitted = disparityRms(fitAlongRays(pts, o));
  o.robust_iterations = 0;
  const double least_squares = disparityRms(fitAlongRays(pts, o));
  std::printf("\ndisparity error RMS 20-55 m: raw %.3f px, fitted %.3f px, fitted without reweighting %.3f px\n", raw,
              fitted, least_squares);
  CHECK(raw > 0.3);
  CHECK(fitted < 0.4 * raw);
  CHECK(fitted < least_squares);
  // The points stay on their rays: azimuth and depression unchanged.
  o.robust_iterations = EquiParallaxOptions{}.robust_iterations;
  const std::vector<DemPoint> moved = fitAlongRays(pts, o);
  for (std::size_t i = 0; i < pts.size(); i += 97) {
    DOUBLES_EQUAL(std::atan2(pts[i].east_m, pts[i].north_m), std::atan2(moved[i].east_m, moved[i].north_m), 1e-9);
    DOUBLES_EQUAL(std::atan2(pts[i].elevation_m - 1.5, std::hypot(pts[i].north_m, pts[i].east_m)),
                  std::atan2(moved[i].elevation_m - 1.5, std::hypot(moved[i].north_m, moved[i].east_m)), 1e-9);
  }
}
