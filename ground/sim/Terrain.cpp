#include "ground/sim/Terrain.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include "ground/sim/Noise.hpp"
#include "ground/sim/Parallel.hpp"

namespace areomap::sim {

struct Terrain::GridRay {
  double u0, v0, du, dv;  // node coordinates (row ix along u = north, column iy along v = east)
  double e0, de;          // elevation up along the ray
  double u(double t) const { return u0 + t * du; }
  double v(double t) const { return v0 + t * dv; }
  double e(double t) const { return e0 + t * de; }
};

namespace {

constexpr int kMaxRaySteps = 1 << 22;      // bound of the mip-map walk (a ray crosses at most ~4 n cells)
constexpr double kRockTileM = 1.0;         // rocks are drawn per 1 m x 1 m tile
constexpr double kMaxRockM = 2.5;          // largest rock diameter
constexpr double kRockFreeRadiusM = 1.2;   // the rover's footprint stays clear
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

}  // namespace

struct Terrain::Rock {
  double x, y, radius, height, bury, albedo, phase1, phase2, squash;
  double base;  // surface elevation under the centre before any rock
};

double Terrain::coverHalfExtentM(const SimConfig& config) {
  const int n = static_cast<int>(std::lround(2.0 * config.half_extent_m / config.cell_m)) + 1;
  return std::max(0.5 * (n - 1) * config.cell_m, kMinCoverHalfM);
}

Terrain Terrain::build(const SimConfig& config) {
  Terrain t;
  t.seed_ = mix64(config.seed ^ 0x7e88a1dULL);
  Grid& f = t.fine_;
  f.cell = config.cell_m;
  f.n = static_cast<int>(std::lround(2.0 * config.half_extent_m / config.cell_m)) + 1;
  f.x0 = -0.5 * (f.n - 1) * f.cell;
  f.y0 = f.x0;
  t.texture_ifov_rad_ = 1.0 / config.focalPx();
  const int n = f.n;
  const double fine_half = 0.5 * (n - 1) * f.cell;
  const double cover_half = coverHalfExtentM(config);
  const bool has_coarse = cover_half > fine_half + 1e-9;
  if (has_coarse) {
    Grid& c = t.coarse_;
    c.cell = kCoarseCellM;
    c.n = static_cast<int>(std::lround(2.0 * cover_half / c.cell)) + 1;
    c.x0 = -0.5 * (c.n - 1) * c.cell;
    c.y0 = c.x0;
  }

  // Relief and albedo: multi-octave value noise down to ~4 fine cells, a regional slope, albedo patches.
  // The coarse grid evaluates the same function (same octaves) at its nodes.
  std::mt19937_64 rng(t.seed_);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const double slope_az = 2.0 * M_PI * uni(rng);
  const double slope = 0.003 + 0.009 * uni(rng);
  int octaves = 0;
  for (double w = 32.0; w >= 6.0 * f.cell && octaves < 14; w *= 0.5) ++octaves;
  const uint64_t s_relief = t.seed_ + 1, s_patch = t.seed_ + 2, s_dust = t.seed_ + 3, s_mottle = t.seed_ + 4;
  const double relief_scale = 2.6 * config.relief_m;  // value-noise fBm has an RMS of ~0.38
  auto fill = [&](Grid& g) {
    const int gn = g.n;
    g.h.assign(static_cast<std::size_t>(gn) * gn, 0.0f);
    g.albedo.assign(static_cast<std::size_t>(gn) * gn, 0.0f);
    parallelFor(gn, config.threads, [&](int ix) {
      const double x = g.x0 + ix * g.cell;
      for (int iy = 0; iy < gn; ++iy) {
        const double y = g.y0 + iy * g.cell;
        const double relief = relief_scale * fbm(s_relief, x, y, 32.0, octaves, 0.55);
        const double regional = slope * (x * std::cos(slope_az) + y * std::sin(slope_az));
        g.h[static_cast<std::size_t>(ix) * gn + iy] = static_cast<float>(relief + regional);
        // Bright and dark patches (smooth threshold of low-frequency noise), dust mottling, fine variation.
        const double patch = fbm(s_patch, x, y, 8.0, 3, 0.5);
        const double patches = std::tanh(4.0 * patch) * 0.22;
        const double dust = 0.15 * fbm(s_dust, x, y, 1.5, 3, 0.6);
        const double mottle = 0.2 * fbm(s_mottle, x, y, 0.4, 3, 0.7);
        g.albedo[static_cast<std::size_t>(ix) * gn + iy] =
            static_cast<float>(0.24 * (1.0 + patches) * (1.0 + dust) * (1.0 + mottle));
      }
    });
  };
  fill(f);
  if (has_coarse) fill(t.coarse_);

  // Craters: a bowl with a raised rim; radii from a cumulative power law N(>R) ~ R^-2 on [1.5, 10] m.
  auto apply_crater = [&](Grid& g, double cx, double cy, double radius, double depth, double rim) {
    const int gn = g.n;
    const int i0 = std::max(0, static_cast<int>((cx - 3.0 * radius - g.x0) / g.cell));
    const int i1 = std::min(gn - 1, static_cast<int>((cx + 3.0 * radius - g.x0) / g.cell) + 1);
    const int j0 = std::max(0, static_cast<int>((cy - 3.0 * radius - g.y0) / g.cell));
    const int j1 = std::min(gn - 1, static_cast<int>((cy + 3.0 * radius - g.y0) / g.cell) + 1);
    if (i0 > i1 || j0 > j1) return false;
    parallelFor(i1 - i0 + 1, config.threads, [&](int k) {
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
  };
  const double area_km2 = std::pow(2.0 * config.half_extent_m / 1000.0, 2);
  const int crater_count = drawPoisson(rng, config.crater_density_per_km2 * area_km2);
  for (int c = 0; c < crater_count; ++c) {
    const double r_min = 1.5, r_max = 10.0;
    const double radius = 1.0 / std::sqrt(1.0 / (r_min * r_min) - uni(rng) * (1.0 / (r_min * r_min) - 1.0 / (r_max * r_max)));
    const double cx = (2.0 * uni(rng) - 1.0) * config.half_extent_m;
    const double cy = (2.0 * uni(rng) - 1.0) * config.half_extent_m;
    if (std::hypot(cx, cy) < radius * 3.0 + 2.0) continue;  // keep the rover off crater walls
    const double depth = radius * (0.06 + 0.08 * uni(rng));  // degraded craters
    const double rim = radius * (0.015 + 0.02 * uni(rng));
    const bool on_fine = apply_crater(f, cx, cy, radius, depth, rim);
    if (has_coarse) apply_crater(t.coarse_, cx, cy, radius, depth, rim);
    if (on_fine) ++t.craters_;
  }
  if (has_coarse) {
    // Craters of the outer ring (own random stream, so the fine grid does not depend on it): drawn over the
    // whole covered square at the same density, kept only where they do not reach the fine grid.
    std::mt19937_64 outer_rng(t.seed_ + 7);
    const int outer_count = drawPoisson(outer_rng, config.crater_density_per_km2 * std::pow(2.0 * cover_half / 1000.0, 2));
    for (int c = 0; c < outer_count; ++c) {
      const double r_min = 1.5, r_max = 10.0;
      const double radius = 1.0 / std::sqrt(1.0 / (r_min * r_min) - uni(outer_rng) * (1.0 / (r_min * r_min) - 1.0 / (r_max * r_max)));
      const double cx = (2.0 * uni(outer_rng) - 1.0) * cover_half;
      const double cy = (2.0 * uni(outer_rng) - 1.0) * cover_half;
      const double depth = radius * (0.06 + 0.08 * uni(outer_rng));
      const double rim = radius * (0.015 + 0.02 * uni(outer_rng));
      if (std::fabs(cx) < fine_half + 3.0 * radius && std::fabs(cy) < fine_half + 3.0 * radius) continue;
      if (apply_crater(t.coarse_, cx, cy, radius, depth, rim)) ++t.craters_;
    }
  }

  // Rocks (fine grid only): per tile, the Golombek density above a minimum diameter that grows with range
  // (centimetre detail near the rover, coarser far away) and never below three cells (a rock must be resolved).
  std::vector<Terrain::Rock> rocks;
  const int tiles = static_cast<int>(std::ceil(2.0 * config.half_extent_m / kRockTileM));
  for (int tx = 0; tx < tiles; ++tx) {
    for (int ty = 0; ty < tiles; ++ty) {
      const double ax = -config.half_extent_m + tx * kRockTileM, ay = -config.half_extent_m + ty * kRockTileM;
      const double range = std::hypot(ax + 0.5 * kRockTileM, ay + 0.5 * kRockTileM);
      const double d_min = std::max({config.min_rock_m, 3.0 * f.cell, 0.006 * range});
      std::mt19937_64 tile_rng(hash3(t.seed_ + 5, tx, ty));
      const int count = drawPoisson(tile_rng, golombekRockDensity(config.rock_k, d_min, kMaxRockM) * kRockTileM * kRockTileM);
      std::uniform_real_distribution<double> u(0.0, 1.0);
      for (int r = 0; r < count; ++r) {
        Terrain::Rock rock;
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
        if (std::hypot(rock.x, rock.y) < kRockFreeRadiusM + rock.radius) continue;
        rocks.push_back(rock);
      }
    }
  }
  // Larger rocks last, so that they stand over the small ones (painter's order, deterministic).
  std::stable_sort(rocks.begin(), rocks.end(), [](const Rock& a, const Rock& b) { return a.radius < b.radius; });
  // Each rock stands on the surface under its centre before any rock is placed (so bases do not depend on
  // the order of work); bands of rows are rasterised in parallel, every band taking the rocks in order.
  for (Rock& rock : rocks) {
    const int ci = std::clamp(static_cast<int>(std::lround((rock.x - f.x0) / f.cell)), 0, n - 1);
    const int cj = std::clamp(static_cast<int>(std::lround((rock.y - f.y0) / f.cell)), 0, n - 1);
    rock.base = f.h[static_cast<std::size_t>(ci) * n + cj];
  }
  const uint64_t s_rock = t.seed_ + 6;
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
  t.rocks_ = static_cast<int>(rocks.size());

  // Elevation ranges and the far plane (mean of the outermost grid's edge nodes).
  for (Grid* g : {&t.fine_, &t.coarse_}) {
    if (g->n == 0) continue;
    const auto [lo, hi] = std::minmax_element(g->h.begin(), g->h.end());
    g->h_min = *lo;
    g->h_max = *hi;
    g->buildMaxMipmap();
  }
  t.h_min_ = has_coarse ? std::min(f.h_min, t.coarse_.h_min) : f.h_min;
  t.h_max_ = has_coarse ? std::max(f.h_max, t.coarse_.h_max) : f.h_max;
  const Grid& outer = has_coarse ? t.coarse_ : f;
  double edge = 0.0;
  for (int i = 0; i < outer.n; ++i) edge += outer.node(0, i) + outer.node(outer.n - 1, i) + outer.node(i, 0) + outer.node(i, outer.n - 1);
  t.h_far_ = static_cast<float>(edge / (4.0 * outer.n));
  return t;
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
      const double outline = rock.radius * (1.0 + 0.12 * std::sin(3.0 * theta + rock.phase2) + 0.07 * std::sin(5.0 * theta + rock.phase1));
      const double rho = std::hypot(along, across) / outline;
      if (rho >= 1.0) continue;
      const double bump = 0.08 * rock.height * valueNoise(s_rock, dx / (0.3 * rock.radius) + rock.x, dy / (0.3 * rock.radius) + rock.y);
      const double top = base - rock.bury + rock.height * std::pow(1.0 - rho * rho, 0.6) + bump * (1.0 - rho);
      float& h = t.h[static_cast<std::size_t>(ix) * n + iy];
      if (top > h) {
        h = static_cast<float>(top);
        float& a = t.albedo[static_cast<std::size_t>(ix) * n + iy];
        a = static_cast<float>(0.22 * rock.albedo * (1.0 + 0.25 * valueNoise(s_rock + 1, dx / 0.04, dy / 0.04)));
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
        if (2 * i + 1 < s && 2 * j + 1 < s) m = std::max(m, prev[static_cast<std::size_t>(2 * i + 1) * s + 2 * j + 1]);
        next[static_cast<std::size_t>(i) * s2 + j] = m;
      }
    }
    mip_.push_back(std::move(next));
    mip_size_.push_back(s2);
  }
}

bool Terrain::Grid::inside(double x_m, double y_m) const {
  const double u = (x_m - x0) / cell, v = (y_m - y0) / cell;
  return u >= 0.0 && v >= 0.0 && u <= n - 1 && v <= n - 1;
}

double Terrain::Grid::elevation(double x_m, double y_m) const {
  const double u = std::clamp((x_m - x0) / cell, 0.0, n - 1.0), v = std::clamp((y_m - y0) / cell, 0.0, n - 1.0);
  const int i = std::min(static_cast<int>(u), n - 2), j = std::min(static_cast<int>(v), n - 2);
  const double fu = u - i, fv = v - j;
  return node(i, j) * (1 - fu) * (1 - fv) + node(i + 1, j) * fu * (1 - fv) + node(i, j + 1) * (1 - fu) * fv +
         node(i + 1, j + 1) * fu * fv;
}

Eigen::Vector3d Terrain::Grid::normal(double x_m, double y_m) const {
  const double u = std::clamp((x_m - x0) / cell, 0.0, n - 1.0), v = std::clamp((y_m - y0) / cell, 0.0, n - 1.0);
  const int i = std::min(static_cast<int>(u), n - 2), j = std::min(static_cast<int>(v), n - 2);
  const double fu = u - i, fv = v - j;
  const double hx = ((node(i + 1, j) - node(i, j)) * (1 - fv) + (node(i + 1, j + 1) - node(i, j + 1)) * fv) / cell;
  const double hy = ((node(i, j + 1) - node(i, j)) * (1 - fu) + (node(i + 1, j + 1) - node(i + 1, j)) * fu) / cell;
  return Eigen::Vector3d(-hx, -hy, -1.0).normalized();
}

double Terrain::Grid::albedoAt(double x_m, double y_m) const {
  const double u = std::clamp((x_m - x0) / cell, 0.0, n - 1.0), v = std::clamp((y_m - y0) / cell, 0.0, n - 1.0);
  const int i = std::min(static_cast<int>(u), n - 2), j = std::min(static_cast<int>(v), n - 2);
  const double fu = u - i, fv = v - j;
  auto a = [&](int ii, int jj) { return static_cast<double>(albedo[static_cast<std::size_t>(ii) * n + jj]); };
  return a(i, j) * (1 - fu) * (1 - fv) + a(i + 1, j) * fu * (1 - fv) + a(i, j + 1) * (1 - fu) * fv + a(i + 1, j + 1) * fu * fv;
}

bool Terrain::inside(double x_m, double y_m) const { return fine_.inside(x_m, y_m) || (coarse_.n > 0 && coarse_.inside(x_m, y_m)); }

double Terrain::halfExtentM() const {
  const Grid& g = coarse_.n > 0 ? coarse_ : fine_;
  const double far = (g.n - 1) * g.cell;
  return std::min({-g.x0, g.x0 + far, -g.y0, g.y0 + far});
}

double Terrain::elevation(double x_m, double y_m) const { return gridAt(x_m, y_m).elevation(x_m, y_m); }

Eigen::Vector3d Terrain::normal(double x_m, double y_m) const { return gridAt(x_m, y_m).normal(x_m, y_m); }

double Terrain::albedo(double x_m, double y_m) const {
  double value = gridAt(x_m, y_m).albedoAt(x_m, y_m);
  // Fine texture (grain and pebbles below the grid cell), band-limited like a mip-map: an octave of
  // wavelength L fades out where L < 3 pixel footprints at that range (so views alias it alike).
  const double footprint_m = std::max(1e-3, std::hypot(x_m, y_m) * texture_ifov_rad_);
  double fine = 0.0;
  double wavelength = 0.012;
  for (int octave = 0; octave < 5; ++octave, wavelength *= 2.0) {
    const double weight = std::clamp(wavelength / (1.5 * footprint_m) - 1.0, 0.0, 1.0);
    if (weight > 0.0) fine += weight * 0.16 * valueNoise(seed_ + 20 + octave, x_m / wavelength, y_m / wavelength);
  }
  constexpr double kPebbleCellM = 0.03;
  const double pebble_weight = std::clamp(kPebbleCellM / (1.5 * footprint_m) - 1.0, 0.0, 1.0);
  if (pebble_weight > 0.0) {
    const double px = x_m / kPebbleCellM, py = y_m / kPebbleCellM;
    const int64_t pi = static_cast<int64_t>(std::floor(px)), pj = static_cast<int64_t>(std::floor(py));
    const uint64_t h = hash3(seed_ + 12, pi, pj);
    if (unit(h) < 0.3) {
      const double cx = pi + 0.3 + 0.4 * unit(mix64(h + 1)), cy = pj + 0.3 + 0.4 * unit(mix64(h + 2));
      const double radius = 0.15 + 0.15 * unit(mix64(h + 3));
      const double d = std::hypot(px - cx, py - cy) / radius;
      if (d < 1.0) fine += pebble_weight * (unit(mix64(h + 4)) < 0.5 ? -0.4 : 0.45) * (1.0 - d * d);
    }
  }
  value *= 1.0 + fine;
  return std::clamp(value, 0.01, 1.0);
}

bool Terrain::Grid::intersectCell(int ci, int cj, const GridRay& ray, double ta, double tb, double& t_hit) const {
  const double h00 = node(ci, cj), h10 = node(ci + 1, cj), h01 = node(ci, cj + 1), h11 = node(ci + 1, cj + 1);
  auto g = [&](double t) {
    const double fu = ray.u(t) - ci, fv = ray.v(t) - cj;
    return ray.e(t) - (h00 * (1 - fu) * (1 - fv) + h10 * fu * (1 - fv) + h01 * (1 - fu) * fv + h11 * fu * fv);
  };
  // Along the ray the bilinear surface is quadratic in t: fit g(s) = a s^2 + b s + c exactly from 3 samples.
  const double g0 = g(ta);
  if (g0 <= 0.0) {
    t_hit = ta;
    return true;
  }
  const double gm = g(0.5 * (ta + tb)), g1 = g(tb);
  const double a = 2.0 * g1 + 2.0 * g0 - 4.0 * gm, b = 4.0 * gm - 3.0 * g0 - g1, c = g0;
  double s = 2.0;
  if (std::fabs(a) < 1e-12 * (std::fabs(b) + std::fabs(c))) {
    if (b < 0.0) s = -c / b;
  } else {
    const double disc = b * b - 4.0 * a * c;
    if (disc >= 0.0) {
      const double sq = std::sqrt(disc);
      const double q = -0.5 * (b + (b >= 0.0 ? sq : -sq));
      const double r1 = q / a, r2 = q != 0.0 ? c / q : 2.0;
      const double lo = std::min(r1, r2), hi = std::max(r1, r2);
      s = lo >= 0.0 ? lo : hi;
    }
  }
  if (s < 0.0 || s > 1.0) return false;
  t_hit = ta + s * (tb - ta);
  return true;
}

bool Terrain::Grid::castRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_lo, double t_hi,
                            double& t_hit) const {
  const int n_ = n;
  const double x0_ = x0, y0_ = y0, cell_ = cell;
  const float h_min_ = h_min, h_max_ = h_max;
  const auto& mip_ = mip;
  const auto& mip_size_ = mip_size;
  GridRay ray{(origin.x() - x0_) / cell_, (origin.y() - y0_) / cell_, direction.x() / cell_, direction.y() / cell_,
              -origin.z(), -direction.z()};
  const int cells = n_ - 1;
  // Clip to the grid square.
  double ta = 0.0, tb = 0.0;
  if (!clip(origin, direction, ta, tb)) return false;
  double t0 = std::max(t_lo, ta), t1 = std::min(t_hi, tb);
  // Clip to the elevation range: above the highest node going up, or below the lowest, nothing is hit.
  if (ray.de > 0.0) {
    t1 = std::min(t1, (h_max_ - ray.e0) / ray.de);
  } else if (ray.de < 0.0) {
    t1 = std::min(t1, (h_min_ - 1e-3 - ray.e0) / ray.de);
  } else if (ray.e0 > h_max_) {
    return false;
  }
  if (!(t0 < t1)) return false;

  const int top = static_cast<int>(mip_.size());  // levels 1..top are stored in mip_[level - 1]
  int level = top;
  double t = t0;
  const double inv_du = ray.du != 0.0 ? 1.0 / ray.du : 0.0, inv_dv = ray.dv != 0.0 ? 1.0 / ray.dv : 0.0;
  const double nudge_u = ray.du > 0.0 ? 1e-7 : (ray.du < 0.0 ? -1e-7 : 0.0);
  const double nudge_v = ray.dv > 0.0 ? 1e-7 : (ray.dv < 0.0 ? -1e-7 : 0.0);
  for (int step = 0; step < kMaxRaySteps && t < t1; ++step) {
    // The cell the ray is in (or entering, when exactly on a boundary); outside the grid it has left.
    const double fu = std::floor(ray.u(t) + nudge_u), fv = std::floor(ray.v(t) + nudge_v);
    if (fu < 0.0 || fv < 0.0 || fu >= cells || fv >= cells) return false;
    const int ci = static_cast<int>(fu), cj = static_cast<int>(fv);
    const int bi = ci >> level, bj = cj >> level;
    const double lo_u = static_cast<double>(bi << level), hi_u = std::min(static_cast<double>((bi + 1) << level), static_cast<double>(cells));
    const double lo_v = static_cast<double>(bj << level), hi_v = std::min(static_cast<double>((bj + 1) << level), static_cast<double>(cells));
    double tx = t1;
    if (ray.du > 0.0) tx = std::min(tx, (hi_u - ray.u0) * inv_du);
    if (ray.du < 0.0) tx = std::min(tx, (lo_u - ray.u0) * inv_du);
    if (ray.dv > 0.0) tx = std::min(tx, (hi_v - ray.v0) * inv_dv);
    if (ray.dv < 0.0) tx = std::min(tx, (lo_v - ray.v0) * inv_dv);
    tx = std::max(tx, t);
    const double e_min = std::min(ray.e(t), ray.e(tx));
    const float block_max =
        level == 0 ? std::max({node(ci, cj), node(ci + 1, cj), node(ci, cj + 1), node(ci + 1, cj + 1)})
                   : mip_[static_cast<std::size_t>(level - 1)]
                         [static_cast<std::size_t>(bi) * mip_size_[static_cast<std::size_t>(level - 1)] + bj];
    if (e_min > block_max) {
      t = tx;
      if (level < top) ++level;
      continue;
    }
    if (level > 0) {
      --level;
      continue;
    }
    if (intersectCell(ci, cj, ray, t, tx, t_hit)) return true;
    t = tx;
    if (level < top) ++level;
  }
  return false;
}

bool Terrain::Grid::clip(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double& ta, double& tb) const {
  const double uv0[2] = {(origin.x() - x0) / cell, (origin.y() - y0) / cell};
  const double duv[2] = {direction.x() / cell, direction.y() / cell};
  const int cells = n - 1;
  ta = -std::numeric_limits<double>::infinity();
  tb = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 2; ++k) {
    if (std::fabs(duv[k]) < 1e-15) {
      if (uv0[k] < 0.0 || uv0[k] > cells) return false;
      continue;
    }
    double a = (0.0 - uv0[k]) / duv[k], b = (cells - uv0[k]) / duv[k];
    if (a > b) std::swap(a, b);
    ta = std::max(ta, a);
    tb = std::min(tb, b);
  }
  return ta < tb;
}

bool Terrain::castRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double& t_hit, double t_max) const {
  if (coarse_.n == 0) return fine_.castRay(origin, direction, 0.0, t_max, t_hit);
  // Over the fine square the fine grid; before and after it, the coarse one.
  double a = 0.0, b = 0.0;
  if (fine_.clip(origin, direction, a, b)) {
    a = std::max(a, 0.0);
    b = std::min(b, t_max);
    if (a < b) {
      if (a > 0.0 && coarse_.castRay(origin, direction, 0.0, a, t_hit)) return true;
      if (fine_.castRay(origin, direction, a, b, t_hit)) return true;
      return coarse_.castRay(origin, direction, b, t_max, t_hit);
    }
  }
  return coarse_.castRay(origin, direction, 0.0, t_max, t_hit);
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
          fi >= 0 && fi < f.n && fj >= 0 && fj < f.n ? f.node(fi, fj)
                                                     : static_cast<float>(coarse_.elevation(x0 + ix * f.cell, y0 + col * f.cell));
    }
  }
  return g;
}

}  // namespace areomap::sim
