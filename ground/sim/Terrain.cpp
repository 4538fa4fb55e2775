// Building the terrain: the grids, relief and albedo, craters, rocks, the mip-maps; the DEM of the result.
// Sampling the surface and casting rays against it are in TerrainSurface.cpp.
#include "ground/sim/Terrain.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include "ground/sim/Noise.hpp"
#include "ground/sim/Parallel.hpp"

namespace areomap::sim {

namespace {

constexpr double kRockTileM = 1.0;        // rocks are drawn per 1 m x 1 m tile
constexpr double kMaxRockM = 2.5;         // largest rock diameter
constexpr double kRockFreeRadiusM = 1.2;  // the rover's footprint stays clear
constexpr int kMaxRocksPerTile = 4000;

}  // namespace

double golombekRockDensity(double k, double d_min, double d_max) {
  if (k <= 0.0 || d_min >= d_max) return 0.0;
  const double q = 1.79 + 0.152 / k;
  constexpr int kSteps = 96;
  const double l0 = std::log(d_min), l1 = std::log(d_max);
  double sum = 0.0;
  for (int i = 0; i < kSteps; ++i) {
    const double d = std::exp(l0 + (i + 0.5) * (l1 - l0) / kSteps);
    sum += 4.0 * k * q * std::exp(-q * d) / (M_PI * d * d) * d;  // dD = D dlogD
  }
  return sum * (l1 - l0) / kSteps;
}

namespace {

// Diameter from n(D) on [d_min, d_max]: proposal ~ 1/D^2 (inverse CDF), accepted with exp(-q (D - d_min)).
double drawRockDiameter(std::mt19937_64& rng, double k, double d_min, double d_max) {
  const double q = 1.79 + 0.152 / k;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double d = d_min;
  for (int i = 0; i < 1000; ++i) {
    d = 1.0 / (1.0 / d_min - u(rng) * (1.0 / d_min - 1.0 / d_max));
    if (u(rng) < std::exp(-q * (d - d_min))) break;
  }
  return d;
}

int drawPoisson(std::mt19937_64& rng, double lambda) {
  if (lambda <= 0.0) return 0;
  if (lambda > 50.0) {
    std::normal_distribution<double> g(lambda, std::sqrt(lambda));
    return std::max(0, static_cast<int>(std::lround(g(rng))));
  }
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double limit = std::exp(-lambda);
  double p = 1.0;
  int k = 0;
  while (k < kMaxRocksPerTile) {
    p *= u(rng);
    if (p <= limit) break;
    ++k;
  }
  return k;
}

// A crater radius from the cumulative power law N(>R) ~ R^-2 on [1.5, 10] m (inverse CDF).
double drawCraterRadius(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const double r_min = 1.5, r_max = 10.0;
  return 1.0 / std::sqrt(1.0 / (r_min * r_min) - uni(rng) * (1.0 / (r_min * r_min) - 1.0 / (r_max * r_max)));
}

}  // namespace

struct Terrain::Crater {
  double cx = 0.0, cy = 0.0, radius = 0.0, depth = 0.0, rim = 0.0;
};

// Relief and albedo: multi-octave value noise down to ~4 fine cells, a regional slope, albedo patches.
// The coarse grid evaluates the same function (same octaves) at its nodes.
struct Terrain::Relief {
  double slope_az = 0.0;
  double slope = 0.0;
  int octaves = 0;
  uint64_t s_relief = 0, s_patch = 0, s_dust = 0, s_mottle = 0;
  double relief_scale = 0.0;
  double swell_gradient = 0.0;  // tan(max_slope_deg): the large-scale swells (SimConfig), 0 none
  Eigen::Vector2d swell_centre = Eigen::Vector2d::Zero();
};

struct Terrain::Rock {
  double x, y, radius, height, bury, albedo, phase1, phase2, squash;
  double base;  // surface elevation under the centre before any rock
};

double Terrain::coverHalfExtentM(const SimConfig& config) {
  const int n = static_cast<int>(std::lround(2.0 * config.half_extent_m / config.cell_m)) + 1;
  return std::max(0.5 * (n - 1) * config.cell_m,
                  config.cover_half_extent_m > 0.0 ? config.cover_half_extent_m : kMinCoverHalfM);
}

Terrain Terrain::build(const SimConfig& config) {
  Terrain t;
  t.seed_ = mix64(config.seed ^ 0x7e88a1dULL);
  t.texture_ifov_rad_ = 1.0 / config.focalPx();
  t.centre_ = config.terrain_centre_m;
  t.rovers_ = config.rover_xy_m;
  if (t.rovers_.empty()) t.rovers_.push_back(Eigen::Vector2d::Zero());
  t.layOutGrids(config);
  // The relief's random draws come first from the terrain's stream, the inner craters' next.
  std::mt19937_64 rng(t.seed_);
  const Relief relief = t.drawRelief(config, rng);
  fillRelief(t.fine_, relief, config.threads);
  if (t.coarse_.n > 0) fillRelief(t.coarse_, relief, config.threads);
  t.addCraters(config, rng);
  if (t.coarse_.n > 0) t.addOuterCraters(config);
  t.addRocks(config);
  t.finishElevations();
  return t;
}

void Terrain::layOutGrids(const SimConfig& config) {
  Grid& f = fine_;
  f.cell = config.cell_m;
  f.n = static_cast<int>(std::lround(2.0 * config.half_extent_m / config.cell_m)) + 1;
  f.x0 = centre_.x() - 0.5 * (f.n - 1) * f.cell;
  f.y0 = centre_.y() - 0.5 * (f.n - 1) * f.cell;
  const double fine_half = 0.5 * (f.n - 1) * f.cell;
  const double cover_half = coverHalfExtentM(config);
  if (cover_half > fine_half + 1e-9) {
    Grid& c = coarse_;
    c.cell = kCoarseCellM;
    c.n = static_cast<int>(std::lround(2.0 * cover_half / c.cell)) + 1;
    c.x0 = centre_.x() - 0.5 * (c.n - 1) * c.cell;
    c.y0 = centre_.y() - 0.5 * (c.n - 1) * c.cell;
  }
}

Terrain::Relief Terrain::drawRelief(const SimConfig& config, std::mt19937_64& rng) const {
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  Relief r;
  r.slope_az = 2.0 * M_PI * uni(rng);
  r.slope = 0.003 + 0.009 * uni(rng);
  for (double w = 32.0; w >= 6.0 * fine_.cell && r.octaves < 14; w *= 0.5) ++r.octaves;
  r.s_relief = seed_ + 1;
  r.s_patch = seed_ + 2;
  r.s_dust = seed_ + 3;
  r.s_mottle = seed_ + 4;
  r.relief_scale = 2.6 * config.relief_m;  // value-noise fBm has an RMS of ~0.38
  r.swell_gradient = std::tan(config.max_slope_deg * M_PI / 180.0);
  r.swell_centre = config.slope_centre_m;
  return r;
}

void Terrain::fillRelief(Grid& g, const Relief& r, int threads) {
  const int gn = g.n;
  g.h.assign(static_cast<std::size_t>(gn) * gn, 0.0f);
  g.albedo.assign(static_cast<std::size_t>(gn) * gn, 0.0f);
  parallelFor(gn, threads, [&](int ix) {
    const double x = g.x0 + ix * g.cell;
    FbmAlongY relief_noise(r.s_relief, x, 32.0, r.octaves, 0.55), patch_noise(r.s_patch, x, 8.0, 3, 0.5);
    FbmAlongY dust_noise(r.s_dust, x, 1.5, 3, 0.6), mottle_noise(r.s_mottle, x, 0.4, 3, 0.7);
    for (int iy = 0; iy < gn; ++iy) {
      const double y = g.y0 + iy * g.cell;
      const double relief = r.relief_scale * relief_noise(y);
      const double regional = r.slope * (x * std::cos(r.slope_az) + y * std::sin(r.slope_az));
      double height = relief + regional;
      if (r.swell_gradient > 0.0) {
        const double k = 2.0 * M_PI / kSlopeWavelengthM;
        const double range = std::hypot(x - r.swell_centre.x(), y - r.swell_centre.y());
        height -= r.swell_gradient / k * std::cos(k * range);
      }
      g.h[static_cast<std::size_t>(ix) * gn + iy] = static_cast<float>(height);
      // Bright and dark patches (smooth threshold of low-frequency noise), dust mottling, fine variation.
      const double patch = patch_noise(y);
      const double patches = std::tanh(4.0 * patch) * 0.22;
      const double dust = 0.15 * dust_noise(y);
      const double mottle = 0.2 * mottle_noise(y);
      g.albedo[static_cast<std::size_t>(ix) * gn + iy] =
          static_cast<float>(0.24 * (1.0 + patches) * (1.0 + dust) * (1.0 + mottle));
    }
  });
}

// A crater: a bowl with a raised rim. False when it does not reach the grid.
bool Terrain::addCrater(Grid& g, const Crater& crater, int threads) {
  const double cx = crater.cx, cy = crater.cy, radius = crater.radius, depth = crater.depth, rim = crater.rim;
  const int gn = g.n;
  const int i0 = std::max(0, static_cast<int>((cx - 3.0 * radius - g.x0) / g.cell));
  const int i1 = std::min(gn - 1, static_cast<int>((cx + 3.0 * radius - g.x0) / g.cell) + 1);
  const int j0 = std::max(0, static_cast<int>((cy - 3.0 * radius - g.y0) / g.cell));
  const int j1 = std::min(gn - 1, static_cast<int>((cy + 3.0 * radius - g.y0) / g.cell) + 1);
  if (i0 > i1 || j0 > j1) return false;
  parallelFor(i1 - i0 + 1, threads, [&](int k) {
    const int ix = i0 + k;
    const double x = g.x0 + ix * g.cell;
    for (int iy = j0; iy <= j1; ++iy) {
      const double s = std::hypot(x - cx, g.y0 + iy * g.cell - cy) / radius;
      double delta = 0.0;
      if (s < 1.0) {
        delta = (depth + rim) * s * s - depth;
      } else if (s < 3.0) {
        delta = rim * std::pow(s, -3.0) * (1.0 - 0.5 * (s - 1.0));
      }
      g.h[static_cast<std::size_t>(ix) * gn + iy] += static_cast<float>(delta);
    }
  });
  return true;
}

// Craters over the fine square (and the coarse grid under it); radii from a cumulative power law
// N(>R) ~ R^-2 on [1.5, 10] m.
void Terrain::addCraters(const SimConfig& config, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const double area_km2 = std::pow(2.0 * config.half_extent_m / 1000.0, 2);
  const int crater_count = drawPoisson(rng, config.crater_density_per_km2 * area_km2);
  for (int c = 0; c < crater_count; ++c) {
    Crater crater;
    crater.radius = drawCraterRadius(rng);
    crater.cx = centre_.x() + (2.0 * uni(rng) - 1.0) * config.half_extent_m;
    crater.cy = centre_.y() + (2.0 * uni(rng) - 1.0) * config.half_extent_m;
    if (rangeToNearestRover(crater.cx, crater.cy) < crater.radius * 3.0 + 2.0)
      continue;                                               // keep the rover off crater walls
    crater.depth = crater.radius * (0.06 + 0.08 * uni(rng));  // degraded craters
    crater.rim = crater.radius * (0.015 + 0.02 * uni(rng));
    const bool on_fine = addCrater(fine_, crater, config.threads);
    if (coarse_.n > 0) addCrater(coarse_, crater, config.threads);
    if (on_fine) ++craters_;
  }
}

// Craters of the outer ring (own random stream, so the fine grid does not depend on it): drawn over the
// whole covered square at the same density, kept only where they do not reach the fine grid.
void Terrain::addOuterCraters(const SimConfig& config) {
  const double fine_half = 0.5 * (fine_.n - 1) * fine_.cell;
  const double cover_half = coverHalfExtentM(config);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::mt19937_64 outer_rng(seed_ + 7);
  const int outer_count =
      drawPoisson(outer_rng, config.crater_density_per_km2 * std::pow(2.0 * cover_half / 1000.0, 2));
  for (int c = 0; c < outer_count; ++c) {
    Crater crater;
    crater.radius = drawCraterRadius(outer_rng);
    crater.cx = centre_.x() + (2.0 * uni(outer_rng) - 1.0) * cover_half;
    crater.cy = centre_.y() + (2.0 * uni(outer_rng) - 1.0) * cover_half;
    crater.depth = crater.radius * (0.06 + 0.08 * uni(outer_rng));
    crater.rim = crater.radius * (0.015 + 0.02 * uni(outer_rng));
    const double reach = fine_half + 3.0 * crater.radius;
    if (std::fabs(crater.cx - centre_.x()) < reach && std::fabs(crater.cy - centre_.y()) < reach) continue;
    if (addCrater(coarse_, crater, config.threads)) ++craters_;
  }
}

// Rocks (fine grid only): per tile, the Golombek density above a minimum diameter that grows with range
// (centimetre detail near the rover, coarser far away) and never below three cells (a rock must be resolved).
std::vector<Terrain::Rock> Terrain::drawRocks(const SimConfig& config) const {
  std::vector<Rock> rocks;
  const int tiles = static_cast<int>(std::ceil(2.0 * config.half_extent_m / kRockTileM));
  for (int tx = 0; tx < tiles; ++tx) {
    for (int ty = 0; ty < tiles; ++ty) {
      const double ax = centre_.x() - config.half_extent_m + tx * kRockTileM,
                   ay = centre_.y() - config.half_extent_m + ty * kRockTileM;
      const double range = rangeToNearestRover(ax + 0.5 * kRockTileM, ay + 0.5 * kRockTileM);
      const double d_min = std::max({config.min_rock_m, 3.0 * fine_.cell, 0.006 * range});
      std::mt19937_64 tile_rng(hash3(seed_ + 5, tx, ty));
      const int count = drawPoisson(
          tile_rng, golombekRockDensity(config.rock_k, d_min, kMaxRockM) * kRockTileM * kRockTileM);
      std::uniform_real_distribution<double> u(0.0, 1.0);
      for (int r = 0; r < count; ++r) {
        Rock rock;
        rock.x = ax + u(tile_rng) * kRockTileM;
        rock.y = ay + u(tile_rng) * kRockTileM;
        const double d = drawRockDiameter(tile_rng, config.rock_k, d_min, kMaxRockM);
        rock.radius = 0.5 * d;
        rock.height = d * (0.25 + 0.3 * u(tile_rng));
        rock.bury = rock.height * 0.15 * u(tile_rng);
        rock.albedo = 0.55 + 0.8 * u(tile_rng);
        rock.phase1 = 2.0 * M_PI * u(tile_rng);
        rock.phase2 = 2.0 * M_PI * u(tile_rng);
        rock.squash = 0.7 + 0.3 * u(tile_rng);
        if (rangeToNearestRover(rock.x, rock.y) < kRockFreeRadiusM + rock.radius) continue;
        rocks.push_back(rock);
      }
    }
  }
  return rocks;
}

void Terrain::addRocks(const SimConfig& config) {
  std::vector<Rock> rocks = drawRocks(config);
  Grid& f = fine_;
  const int n = f.n;
  // Larger rocks last, so that they stand over the small ones (painter's order, deterministic).
  std::stable_sort(rocks.begin(), rocks.end(),
                   [](const Rock& a, const Rock& b) { return a.radius < b.radius; });
  // Each rock stands on the surface under its centre before any rock is placed (so bases do not depend on
  // the order of work); bands of rows are rasterised in parallel, every band taking the rocks in order.
  for (Rock& rock : rocks) {
    const int ci = std::clamp(static_cast<int>(std::lround((rock.x - f.x0) / f.cell)), 0, n - 1);
    const int cj = std::clamp(static_cast<int>(std::lround((rock.y - f.y0) / f.cell)), 0, n - 1);
    rock.base = f.h[static_cast<std::size_t>(ci) * n + cj];
  }
  const uint64_t s_rock = seed_ + 6;
  constexpr int kBandRows = 64;
  parallelFor((n + kBandRows - 1) / kBandRows, config.threads, [&](int band) {
    const int band_lo = band * kBandRows, band_hi = std::min(n - 1, band_lo + kBandRows - 1);
    for (const Rock& rock : rocks) {
      const double reach = rock.radius * 1.3;
      const int i0 = std::max(band_lo, static_cast<int>(std::floor((rock.x - reach - f.x0) / f.cell)));
      const int i1 = std::min(band_hi, static_cast<int>(std::ceil((rock.x + reach - f.x0) / f.cell)));
      const int j0 = std::max(0, static_cast<int>(std::floor((rock.y - reach - f.y0) / f.cell)));
      const int j1 = std::min(n - 1, static_cast<int>(std::ceil((rock.y + reach - f.y0) / f.cell)));
      if (i0 > i1 || j0 > j1) continue;
      rasterRock(f, rock, s_rock, i0, i1, j0, j1);
    }
  });
  rocks_ = static_cast<int>(rocks.size());
}

// Elevation ranges, the mip-maps and the far plane (mean of the outermost grid's edge nodes).
void Terrain::finishElevations() {
  const bool has_coarse = coarse_.n > 0;
  for (Grid* g : {&fine_, &coarse_}) {
    if (g->n == 0) continue;
    const auto [lo, hi] = std::minmax_element(g->h.begin(), g->h.end());
    g->h_min = *lo;
    g->h_max = *hi;
    g->buildMaxMipmap();
  }
  h_min_ = has_coarse ? std::min(fine_.h_min, coarse_.h_min) : fine_.h_min;
  h_max_ = has_coarse ? std::max(fine_.h_max, coarse_.h_max) : fine_.h_max;
  const Grid& outer = has_coarse ? coarse_ : fine_;
  double edge = 0.0;
  for (int i = 0; i < outer.n; ++i) {
    edge += outer.node(0, i) + outer.node(outer.n - 1, i) + outer.node(i, 0) + outer.node(i, outer.n - 1);
  }
  h_far_ = static_cast<float>(edge / (4.0 * outer.n));
}

void Terrain::rasterRock(Grid& t, const Rock& rock, uint64_t s_rock, int i0, int i1, int j0, int j1) {
  const int n = t.n;
  const double base = rock.base;
  const double cos_a = std::cos(rock.phase1), sin_a = std::sin(rock.phase1);
  for (int ix = i0; ix <= i1; ++ix) {
    for (int iy = j0; iy <= j1; ++iy) {
      const double dx = t.x0 + ix * t.cell - rock.x, dy = t.y0 + iy * t.cell - rock.y;
      // Elongated, irregular outline.
      const double along = dx * cos_a + dy * sin_a, across = (-dx * sin_a + dy * cos_a) / rock.squash;
      const double theta = std::atan2(across, along);
      const double outline = rock.radius * (1.0 + 0.12 * std::sin(3.0 * theta + rock.phase2) +
                                            0.07 * std::sin(5.0 * theta + rock.phase1));
      const double rho = std::hypot(along, across) / outline;
      if (rho >= 1.0) continue;
      const double bump =
          0.08 * rock.height *
          valueNoise(s_rock, dx / (0.3 * rock.radius) + rock.x, dy / (0.3 * rock.radius) + rock.y);
      const double top = base - rock.bury + rock.height * std::pow(1.0 - rho * rho, 0.6) + bump * (1.0 - rho);
      float& h = t.h[static_cast<std::size_t>(ix) * n + iy];
      if (top > h) {
        h = static_cast<float>(top);
        float& a = t.albedo[static_cast<std::size_t>(ix) * n + iy];
        a = static_cast<float>(0.22 * rock.albedo *
                               (1.0 + 0.25 * valueNoise(s_rock + 1, dx / 0.04, dy / 0.04)));
      }
    }
  }
}

void Terrain::Grid::buildMaxMipmap() {
  // Level 0 (single cells) is not stored: castRay takes the maximum of the cell's four nodes. Level 1 (2 x 2
  // cells) is built from the nodes, every next level from the one below.
  const int n_ = n;
  auto& mip_ = mip;
  auto& mip_size_ = mip_size;
  const int cells = n_ - 1;
  mip_.clear();
  mip_size_.clear();
  const int s1 = (cells + 1) / 2;
  std::vector<float> level(static_cast<std::size_t>(s1) * s1);
  for (int i = 0; i < s1; ++i) {
    for (int j = 0; j < s1; ++j) {
      float m = node(2 * i, 2 * j);
      for (int a = 2 * i; a <= std::min(2 * i + 2, n_ - 1); ++a) {
        for (int b = 2 * j; b <= std::min(2 * j + 2, n_ - 1); ++b) m = std::max(m, node(a, b));
      }
      level[static_cast<std::size_t>(i) * s1 + j] = m;
    }
  }
  mip_.push_back(std::move(level));
  mip_size_.push_back(s1);
  while (mip_size_.back() > 1) {
    const int s = mip_size_.back();
    const int s2 = (s + 1) / 2;
    const std::vector<float>& prev = mip_.back();
    std::vector<float> next(static_cast<std::size_t>(s2) * s2);
    for (int i = 0; i < s2; ++i) {
      for (int j = 0; j < s2; ++j) {
        float m = prev[static_cast<std::size_t>(2 * i) * s + 2 * j];
        if (2 * i + 1 < s) m = std::max(m, prev[static_cast<std::size_t>(2 * i + 1) * s + 2 * j]);
        if (2 * j + 1 < s) m = std::max(m, prev[static_cast<std::size_t>(2 * i) * s + 2 * j + 1]);
        if (2 * i + 1 < s && 2 * j + 1 < s)
          m = std::max(m, prev[static_cast<std::size_t>(2 * i + 1) * s + 2 * j + 1]);
        next[static_cast<std::size_t>(i) * s2 + j] = m;
      }
    }
    mip_.push_back(std::move(next));
    mip_size_.push_back(s2);
  }
}

DemGrid Terrain::dem() const {
  // The fine lattice, extended outward by whole fine cells over the coarse grid.
  const Grid& f = fine_;
  int k = 0;
  if (coarse_.n > 0) {
    const double fine_half = 0.5 * (f.n - 1) * f.cell, coarse_half = 0.5 * (coarse_.n - 1) * coarse_.cell;
    k = std::max(0, static_cast<int>(std::floor((coarse_half - fine_half) / f.cell + 1e-9)));
  }
  const int n = f.n + 2 * k;
  const double x0 = f.x0 - k * f.cell, y0 = f.y0 - k * f.cell;
  DemGrid g;
  g.cols = n;
  g.rows = n;
  g.cell_m = f.cell;
  g.east0_m = y0 - 0.5 * f.cell;
  g.north0_m = x0 + (n - 1) * f.cell + 0.5 * f.cell;
  g.values.resize(static_cast<std::size_t>(n) * n);
  for (int row = 0; row < n; ++row) {
    const int ix = n - 1 - row, fi = ix - k;
    for (int col = 0; col < n; ++col) {
      const int fj = col - k;
      g.values[static_cast<std::size_t>(row) * n + col] =
          fi >= 0 && fi < f.n && fj >= 0 && fj < f.n
              ? f.node(fi, fj)
              : static_cast<float>(coarse_.elevation(x0 + ix * f.cell, y0 + col * f.cell));
    }
  }
  return g;
}

DemGrid Terrain::demInFrame(const SitePose& terrain_from_frame, const Eigen::Vector2d& centre_m,
                            double half_extent_m, double cell_m) const {
  const int n = static_cast<int>(std::ceil(2.0 * half_extent_m / cell_m - 1e-9));
  DemGrid g;
  g.cols = n;
  g.rows = n;
  g.cell_m = cell_m;
  g.east0_m = centre_m.y() - 0.5 * n * cell_m;
  g.north0_m = centre_m.x() + 0.5 * n * cell_m;
  g.values.resize(static_cast<std::size_t>(n) * n);
  const Eigen::Matrix3d rotation = terrain_from_frame.rotation();
  const double origin_height_m = -terrain_from_frame.position_m.z();  // the frame origin's elevation, up
  parallelFor(n, 0, [&](int row) {
    for (int col = 0; col < n; ++col) {
      const Eigen::Vector3d p = rotation * Eigen::Vector3d(g.northOfRow(row), g.eastOfCol(col), 0.0) +
                                terrain_from_frame.position_m;
      g.values[static_cast<std::size_t>(row) * n + col] =
          inside(p.x(), p.y()) ? static_cast<float>(elevation(p.x(), p.y()) - origin_height_m) : g.nodata;
    }
  });
  return g;
}

}  // namespace areomap::sim
