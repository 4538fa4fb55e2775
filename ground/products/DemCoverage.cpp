#include "ground/products/DemCoverage.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Dense>

#include "firmware_core/match/ParallaxVerifier.hpp"  // medianInPlace

namespace areomap::products {

namespace {

bool seenBy(const CameraModel& m, const Vec3& x) {
  Vec2 p;
  return project(m, x, p) == Status::kOk && p.x() >= -0.5 && p.y() >= -0.5 && p.x() <= m.width - 0.5 &&
         p.y() <= m.height - 0.5;
}


}  // namespace

bool demCellAt(const DemGrid& dem, double north_m, double east_m, double& elevation_m) {
  const double col = std::floor((east_m - dem.east0_m) / dem.cell_m);
  const double row = std::floor((dem.north0_m - north_m) / dem.cell_m);
  if (!(col >= 0 && row >= 0 && col < dem.cols && row < dem.rows)) return false;
  const float v = dem.at(static_cast<int>(col), static_cast<int>(row));
  if (v == dem.nodata || !std::isfinite(v)) return false;
  elevation_m = v;
  return true;
}

bool terrainHides(const DemGrid& dem, const DemGrid* sigma, const Vec3& c, const Vec3& x, double step_m) {
  const double horizontal = std::hypot(x.x() - c.x(), x.y() - c.y());
  const int steps = static_cast<int>(horizontal / (step_m > 0.0 ? step_m : 0.5 * dem.cell_m));
  for (int k = 1; k + 2 < steps; ++k) {
    const Vec3 q = c + (x - c) * (static_cast<double>(k) / steps);
    double z = 0.0, s = 0.0;
    if (!demCellAt(dem, q.x(), q.y(), z)) continue;
    if (sigma == nullptr || !demCellAt(*sigma, q.x(), q.y(), s)) s = 0.0;
    if (z > -q.z() + 2.0 * s) return true;
  }
  return false;
}

double GroundPlane::up(double north_m, double east_m) const {
  return c(0) + c(1) * (north_m - north0_m) + c(2) * (east_m - east0_m);
}

double GroundPlane::sigmaUp(double north_m, double east_m) const {
  const Eigen::Vector3d a(1.0, north_m - north0_m, east_m - east0_m);
  return std::sqrt(sigma_m * sigma_m + std::max(0.0, a.dot(cov * a)));
}

bool fitGroundPlane(const std::vector<Vec3>& points, double min_bound_m, GroundPlane& plane) {
  if (points.size() < 3) return false;
  GroundPlane p;
  for (const Vec3& x : points) {
    p.north0_m += x.x();
    p.east0_m += x.y();
  }
  p.north0_m /= static_cast<double>(points.size());
  p.east0_m /= static_cast<double>(points.size());
  std::vector<bool> use(points.size(), true);
  Eigen::Matrix3d n = Eigen::Matrix3d::Identity();
  for (int round = 0; round < 3; ++round) {
    n.setZero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < points.size(); ++k) {
      if (!use[k]) continue;
      const Eigen::Vector3d a(1.0, points[k].x() - p.north0_m, points[k].y() - p.east0_m);
      n += a * a.transpose();
      g += a * points[k].z();
    }
    p.c = n.ldlt().solve(g);
    std::vector<double> res(points.size());
    for (std::size_t k = 0; k < points.size(); ++k) res[k] = std::abs(points[k].z() - p.up(points[k].x(), points[k].y()));
    std::vector<double> scratch = res;
    p.sigma_m = 1.4826 * medianInPlace(scratch.data(), static_cast<int32_t>(scratch.size()));
    const double bound = std::max(3.0 * p.sigma_m, min_bound_m);
    for (std::size_t k = 0; k < points.size(); ++k) use[k] = res[k] <= bound;
  }
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(n);
  if (!lu.isInvertible()) return false;
  p.cov = p.sigma_m * p.sigma_m * lu.inverse();
  plane = p;
  return plane.c.allFinite() && std::isfinite(plane.sigma_m);
}

bool groundPlane(const DemGrid& dem, const Vec3& centre, double radius_m, GroundPlane& plane) {
  std::vector<Vec3> cells;
  const int reach = static_cast<int>(std::ceil(radius_m / dem.cell_m)) + 1;
  const int col0 = static_cast<int>(std::floor((centre.y() - dem.east0_m) / dem.cell_m));
  const int row0 = static_cast<int>(std::floor((dem.north0_m - centre.x()) / dem.cell_m));
  for (int row = std::max(0, row0 - reach); row <= std::min(dem.rows - 1, row0 + reach); ++row) {
    for (int col = std::max(0, col0 - reach); col <= std::min(dem.cols - 1, col0 + reach); ++col) {
      const float v = dem.at(col, row);
      if (v == dem.nodata || !std::isfinite(v)) continue;
      const double n = dem.northOfRow(row), e = dem.eastOfCol(col);
      if (std::hypot(n - centre.x(), e - centre.y()) > radius_m) continue;
      cells.emplace_back(n, e, v);
    }
  }
  return fitGroundPlane(cells, dem.cell_m, plane);
}

CoverageCount demCoverage(const DemGrid& dem, const DemGrid* sigma, const CameraModel& left,
                          const CameraModel& right, const GroundPlane& plane, double lo_m, double hi_m,
                          double sample_m) {
  CoverageCount count;
  const int k = std::max(1, static_cast<int>(sample_m / dem.cell_m));
  const double step_m = 0.5 * k * dem.cell_m;
  const int reach = static_cast<int>(std::ceil(hi_m / dem.cell_m)) + 1;
  const int col0 = static_cast<int>(std::floor((left.c.y() - dem.east0_m) / dem.cell_m));
  const int row0 = static_cast<int>(std::floor((dem.north0_m - left.c.x()) / dem.cell_m));
  // Every cell of the DEM's lattice, extended beyond its bounds as far as the band reaches.
  for (int row = row0 - reach; row <= row0 + reach; row += k) {
    for (int col = col0 - reach; col <= col0 + reach; col += k) {
      const double north = dem.northOfRow(row), east = dem.eastOfCol(col);
      const double range = std::hypot(north - left.c.x(), east - left.c.y());
      if (range < lo_m || range >= hi_m) continue;
      double up = 0.0;
      const bool filled = demCellAt(dem, north, east, up);
      // A filled cell at its elevation; an empty one at the plane's and at three sigmas either side.
      const double spread = filled ? 0.0 : 3.0 * plane.sigmaUp(north, east);
      if (!filled) up = plane.up(north, east);
      bool seen = true;
      for (const double dz : {0.0, -spread, spread}) {
        const Vec3 x(north, east, -(up + dz));
        seen = seen && seenBy(left, x) && seenBy(right, x) && !terrainHides(dem, sigma, left.c, x, step_m) &&
               !terrainHides(dem, sigma, right.c, x, step_m);
        if (!seen || spread == 0.0) break;
      }
      if (!seen) continue;
      ++count.seen;
      if (filled) ++count.filled;
    }
  }
  return count;
}

}  // namespace areomap::products
