// The built terrain's surface: bilinear sampling of elevation, normal and albedo (with the procedural fine
// texture), and exact ray casting against the bilinear cells, walked down the maximum mip-map.
#include "ground/sim/Terrain.hpp"

#include <algorithm>
#include <cmath>

#include "ground/sim/Noise.hpp"

namespace areomap::sim {

namespace {

constexpr int kMaxRaySteps = 1 << 22;  // bound of the mip-map walk (a ray crosses at most ~4 n cells)

}  // namespace

struct Terrain::GridRay {
  double u0, v0, du, dv;  // node coordinates (row ix along u = north, column iy along v = east)
  double e0, de;          // elevation up along the ray
  double u(double t) const { return u0 + t * du; }
  double v(double t) const { return v0 + t * dv; }
  double e(double t) const { return e0 + t * de; }
};

bool Terrain::Grid::inside(double x_m, double y_m) const {
  const double u = (x_m - x0) / cell, v = (y_m - y0) / cell;
  return u >= 0.0 && v >= 0.0 && u <= n - 1 && v <= n - 1;
}

double Terrain::Grid::elevation(double x_m, double y_m) const {
  const double u = std::clamp((x_m - x0) / cell, 0.0, n - 1.0),
               v = std::clamp((y_m - y0) / cell, 0.0, n - 1.0);
  const int i = std::min(static_cast<int>(u), n - 2), j = std::min(static_cast<int>(v), n - 2);
  const double fu = u - i, fv = v - j;
  return node(i, j) * (1 - fu) * (1 - fv) + node(i + 1, j) * fu * (1 - fv) + node(i, j + 1) * (1 - fu) * fv +
         node(i + 1, j + 1) * fu * fv;
}

Eigen::Vector3d Terrain::Grid::normal(double x_m, double y_m) const {
  const double u = std::clamp((x_m - x0) / cell, 0.0, n - 1.0),
               v = std::clamp((y_m - y0) / cell, 0.0, n - 1.0);
  const int i = std::min(static_cast<int>(u), n - 2), j = std::min(static_cast<int>(v), n - 2);
  const double fu = u - i, fv = v - j;
  const double hx =
      ((node(i + 1, j) - node(i, j)) * (1 - fv) + (node(i + 1, j + 1) - node(i, j + 1)) * fv) / cell;
  const double hy =
      ((node(i, j + 1) - node(i, j)) * (1 - fu) + (node(i + 1, j + 1) - node(i + 1, j)) * fu) / cell;
  return Eigen::Vector3d(-hx, -hy, -1.0).normalized();
}

double Terrain::Grid::albedoAt(double x_m, double y_m) const {
  const double u = std::clamp((x_m - x0) / cell, 0.0, n - 1.0),
               v = std::clamp((y_m - y0) / cell, 0.0, n - 1.0);
  const int i = std::min(static_cast<int>(u), n - 2), j = std::min(static_cast<int>(v), n - 2);
  const double fu = u - i, fv = v - j;
  auto a = [&](int ii, int jj) { return static_cast<double>(albedo[static_cast<std::size_t>(ii) * n + jj]); };
  return a(i, j) * (1 - fu) * (1 - fv) + a(i + 1, j) * fu * (1 - fv) + a(i, j + 1) * (1 - fu) * fv +
         a(i + 1, j + 1) * fu * fv;
}

bool Terrain::inside(double x_m, double y_m) const {
  return fine_.inside(x_m, y_m) || (coarse_.n > 0 && coarse_.inside(x_m, y_m));
}

double Terrain::halfExtentM() const {
  const Grid& g = coarse_.n > 0 ? coarse_ : fine_;
  const double far = (g.n - 1) * g.cell;
  return std::min(
      {centre_.x() - g.x0, g.x0 + far - centre_.x(), centre_.y() - g.y0, g.y0 + far - centre_.y()});
}

double Terrain::rangeToNearestRover(double x_m, double y_m) const {
  // The nearest by squared distance, then its hypot (one rover at the origin: exactly hypot(x, y)).
  std::size_t nearest = 0;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < rovers_.size(); ++k) {
    const double dx = x_m - rovers_[k].x(), dy = y_m - rovers_[k].y();
    const double d2 = dx * dx + dy * dy;
    if (d2 < best) {
      best = d2;
      nearest = k;
    }
  }
  return std::hypot(x_m - rovers_[nearest].x(), y_m - rovers_[nearest].y());
}

double Terrain::elevation(double x_m, double y_m) const {
  return gridAt(x_m, y_m).elevation(x_m, y_m);
}

Eigen::Vector3d Terrain::normal(double x_m, double y_m) const {
  return gridAt(x_m, y_m).normal(x_m, y_m);
}

double Terrain::albedo(double x_m, double y_m) const {
  double value = gridAt(x_m, y_m).albedoAt(x_m, y_m);
  // Fine texture (grain and pebbles below the grid cell), band-limited like a mip-map: an octave of
  // wavelength L fades out where L < 3 pixel footprints at that range (so views alias it alike).
  const double footprint_m = std::max(1e-3, rangeToNearestRover(x_m, y_m) * texture_ifov_rad_);
  double fine = 0.0;
  double wavelength = 0.012;
  for (int octave = 0; octave < 5; ++octave, wavelength *= 2.0) {
    const double weight = std::clamp(wavelength / (1.5 * footprint_m) - 1.0, 0.0, 1.0);
    if (weight > 0.0)
      fine += weight * 0.16 * valueNoise(seed_ + 20 + octave, x_m / wavelength, y_m / wavelength);
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

bool Terrain::Grid::intersectCell(int ci, int cj, const GridRay& ray, double ta, double tb,
                                  double& t_hit) const {
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

bool Terrain::Grid::castRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_lo,
                            double t_hi, double& t_hit) const {
  const int n_ = n;
  const double x0_ = x0, y0_ = y0, cell_ = cell;
  const float h_min_ = h_min, h_max_ = h_max;
  const auto& mip_ = mip;
  const auto& mip_size_ = mip_size;
  GridRay ray{(origin.x() - x0_) / cell_,
              (origin.y() - y0_) / cell_,
              direction.x() / cell_,
              direction.y() / cell_,
              -origin.z(),
              -direction.z()};
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
    const double lo_u = static_cast<double>(bi << level),
                 hi_u = std::min(static_cast<double>((bi + 1) << level), static_cast<double>(cells));
    const double lo_v = static_cast<double>(bj << level),
                 hi_v = std::min(static_cast<double>((bj + 1) << level), static_cast<double>(cells));
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

bool Terrain::Grid::clip(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double& ta,
                         double& tb) const {
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

bool Terrain::castRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double& t_hit,
                      double t_max) const {
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

}  // namespace areomap::sim
