#include "ground/dem/EquiParallax.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <unordered_map>

namespace areomap::dem {

namespace {

constexpr double kPi = 3.14159265358979323846;

double wrapAngle(double a) {
  while (a > kPi) a -= 2.0 * kPi;
  while (a <= -kPi) a += 2.0 * kPi;
  return a;
}

struct Line {
  double ref_az = 0.0;            // azimuth the relative angles are taken from
  std::vector<double> az, r, z, s;  // sorted by relative azimuth
  double median_r = 0.0;
};

struct Sample {
  double r, z, s;
};

// Interpolates a line at relative azimuth `a`; false when `a` is outside or in a gap.
bool sampleLine(const Line& l, double az, double max_gap, Sample& out) {
  const double a = wrapAngle(az - l.ref_az);
  if (l.az.empty() || a < l.az.front() || a > l.az.back()) return false;
  const auto it = std::lower_bound(l.az.begin(), l.az.end(), a);
  std::size_t j = static_cast<std::size_t>(it - l.az.begin());
  if (j == 0) {
    out = Sample{l.r[0], l.z[0], l.s[0]};
    return true;
  }
  const double a0 = l.az[j - 1], a1 = l.az[j];
  if (a1 - a0 > max_gap) return false;
  const double t = a1 > a0 ? (a - a0) / (a1 - a0) : 0.0;
  out = Sample{l.r[j - 1] + t * (l.r[j] - l.r[j - 1]), l.z[j - 1] + t * (l.z[j] - l.z[j - 1]),
               l.s[j - 1] + t * (l.s[j] - l.s[j - 1])};
  return true;
}

void smooth(std::vector<double>& v, int half) {
  if (half <= 0 || v.size() < 3) return;
  std::vector<double> prefix(v.size() + 1, 0.0);
  for (std::size_t i = 0; i < v.size(); ++i) prefix[i + 1] = prefix[i] + v[i];
  const long n = static_cast<long>(v.size());
  for (long i = 0; i < n; ++i) {
    const long a = std::max(0L, i - half), b = std::min(n - 1, i + half);
    v[static_cast<std::size_t>(i)] = (prefix[static_cast<std::size_t>(b + 1)] - prefix[static_cast<std::size_t>(a)]) /
                                     static_cast<double>(b - a + 1);
  }
}

}  // namespace

DemGrid equiParallaxDem(const std::vector<DemPoint>& points, const DemGrid& grid, const EquiParallaxOptions& o,
                        DemGrid* sigma) {
  if (grid.cols <= 0 || grid.rows <= 0) throw std::invalid_argument("equi-parallax: bad grid");
  DemGrid out = grid;
  out.values.assign(static_cast<std::size_t>(grid.cols) * grid.rows, grid.nodata);
  if (sigma != nullptr) *sigma = out;
  const double r_min = o.seam_m - o.blend_m;
  // Lines: points grouped by id, beyond r_min less a margin so that the first lines bracket the blend zone.
  std::unordered_map<int64_t, std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const DemPoint& p = points[i];
    if (p.line < 0) continue;
    if (std::hypot(p.north_m - o.centre_north_m, p.east_m - o.centre_east_m) < r_min - o.max_range_gap_m) continue;
    groups[p.line].push_back(i);
  }
  std::vector<Line> lines;
  lines.reserve(groups.size());
  for (auto& g : groups) {
    if (g.second.size() < 2) continue;
    Line l;
    double sx = 0.0, sy = 0.0;
    for (std::size_t i : g.second) {
      const double a = std::atan2(points[i].east_m - o.centre_east_m, points[i].north_m - o.centre_north_m);
      sx += std::cos(a);
      sy += std::sin(a);
    }
    l.ref_az = std::atan2(sy, sx);
    std::vector<std::pair<double, std::size_t>> order;
    for (std::size_t i : g.second) {
      const double a = std::atan2(points[i].east_m - o.centre_east_m, points[i].north_m - o.centre_north_m);
      order.emplace_back(wrapAngle(a - l.ref_az), i);
    }
    std::sort(order.begin(), order.end());
    for (const auto& e : order) {
      const DemPoint& p = points[e.second];
      l.az.push_back(e.first);
      l.r.push_back(std::hypot(p.north_m - o.centre_north_m, p.east_m - o.centre_east_m));
      l.z.push_back(p.elevation_m);
      l.s.push_back(p.sigma_m);
    }
    smooth(l.r, o.smoothing_half_window);
    smooth(l.z, o.smoothing_half_window);
    std::vector<double> rr = l.r;
    std::nth_element(rr.begin(), rr.begin() + rr.size() / 2, rr.end());
    l.median_r = rr[rr.size() / 2];
    lines.push_back(std::move(l));
  }
  std::sort(lines.begin(), lines.end(), [](const Line& a, const Line& b) { return a.median_r < b.median_r; });
  std::vector<double> medians(lines.size());
  for (std::size_t i = 0; i < lines.size(); ++i) medians[i] = lines[i].median_r;

  for (int row = 0; row < grid.rows; ++row) {
    const double dn = grid.northOfRow(row) - o.centre_north_m;
    for (int col = 0; col < grid.cols; ++col) {
      const double de = grid.eastOfCol(col) - o.centre_east_m;
      const double r = std::hypot(dn, de);
      if (r < r_min) continue;
      const double az = std::atan2(de, dn);
      const std::size_t lo = static_cast<std::size_t>(
          std::lower_bound(medians.begin(), medians.end(), r - o.max_range_gap_m) - medians.begin());
      const std::size_t hi = static_cast<std::size_t>(
          std::upper_bound(medians.begin(), medians.end(), r + o.max_range_gap_m) - medians.begin());
      bool have_below = false, have_above = false;
      Sample below{0, 0, 0}, above{0, 0, 0};
      for (std::size_t i = lo; i < hi; ++i) {
        Sample s;
        if (!sampleLine(lines[i], az, o.max_azimuth_gap_rad, s)) continue;
        if (s.r <= r) {
          if (!have_below || s.r > below.r) below = s;
          have_below = true;
        } else {
          if (!have_above || s.r < above.r) above = s;
          have_above = true;
        }
      }
      if (!have_below || !have_above || above.r - below.r > o.max_range_gap_m) continue;
      const double t = above.r > below.r ? (r - below.r) / (above.r - below.r) : 0.0;
      out.at(col, row) = static_cast<float>(below.z + t * (above.z - below.z));
      if (sigma != nullptr) sigma->at(col, row) = static_cast<float>(below.s + t * (above.s - below.s));
    }
  }
  return out;
}

void blendFarRange(KrigingResult& kriged, const DemGrid& far, const DemGrid* far_sigma, const EquiParallaxOptions& o) {
  DemGrid& z = kriged.elevation;
  DemGrid& s = kriged.sigma;
  if (far.cols != z.cols || far.rows != z.rows) throw std::invalid_argument("blendFarRange: grids differ");
  for (int row = 0; row < z.rows; ++row) {
    for (int col = 0; col < z.cols; ++col) {
      const double r = std::hypot(z.northOfRow(row) - o.centre_north_m, z.eastOfCol(col) - o.centre_east_m);
      const double w = o.blend_m > 0.0 ? std::clamp((r - (o.seam_m - o.blend_m)) / (2.0 * o.blend_m), 0.0, 1.0)
                                        : (r >= o.seam_m ? 1.0 : 0.0);
      if (w <= 0.0) continue;
      const float fz = far.at(col, row);
      if (fz == far.nodata) continue;
      const float kz = z.at(col, row);
      if (kz == z.nodata) {
        z.at(col, row) = fz;
        if (far_sigma != nullptr) s.at(col, row) = far_sigma->at(col, row);
        continue;
      }
      z.at(col, row) = static_cast<float>((1.0 - w) * kz + w * fz);
      if (far_sigma != nullptr) {
        s.at(col, row) = static_cast<float>((1.0 - w) * s.at(col, row) + w * far_sigma->at(col, row));
      }
    }
  }
}

}  // namespace areomap::dem
