#include "ground/products/DemCoverage.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Dense>

#include "firmware_core/match/ParallaxVerifier.hpp"

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

bool groundPlane(const DemGrid& dem, const Vec3& centre, double radius_m, GroundPlane& plane) {
  struct Cell {
    Eigen::Vector3d a;
    double z;
  };
  std::vector<Cell> cells;
  const int reach = static_cast<int>(std::ceil(radius_m / dem.cell_m)) + 1;
  const int col0 = static_cast<int>(std::floor((centre.y() - dem.east0_m) / dem.cell_m));
  const int row0 = static_cast<int>(std::floor((dem.north0_m - centre.x()) / dem.cell_m));
  for (int row = std::max(0, row0 - reach); row <= std::min(dem.rows - 1, row0 + reach); ++row) {
    for (int col = std::max(0, col0 - reach); col <= std::min(dem.cols - 1, col0 + reach); ++col) {
      const float v = dem.at(col, row);
      if (v == dem.nodata || !std::isfinite(v)) continue;
      const double n = dem.northOfRow(row), e = dem.eastOfCol(col);
      if (std::hypot(n - centre.x(), e - centre.y()) > radius_m) continue;
      cells.push_back({Eigen::Vector3d(1.0, n - centre.x(), e - centre.y()), v});
    }
  }
  if (cells.size() < 3) return false;
  std::vector<bool> use(cells.size(), true);
  Eigen::Vector3d local = Eigen::Vector3d::Zero();
  for (int round = 0; round < 3; ++round) {
    Eigen::Matrix3d n = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < cells.size(); ++k) {
      if (!use[k]) continue;
      n += cells[k].a * cells[k].a.transpose();
      g += cells[k].a * cells[k].z;
    }
    local = n.ldlt().solve(g);
    std::vector<double> res(cells.size());
    for (std::size_t k = 0; k < cells.size(); ++k) res[k] = std::abs(cells[k].z - local.dot(cells[k].a));
    // Three robust sigmas, never below a cell's size: a rough but level ground keeps its cells.
    std::vector<double> scratch = res;
    const double bound = std::max(3.0 * 1.4826 * medianInPlace(scratch.data(), static_cast<int32_t>(scratch.size())),
                                  dem.cell_m);
    for (std::size_t k = 0; k < cells.size(); ++k) use[k] = res[k] <= bound;
  }
  // From coordinates relative to the centre back to site coordinates.
  plane = GroundPlane(local(0) - local(1) * centre.x() - local(2) * centre.y(), local(1), local(2));
  return std::isfinite(plane.sum());
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
      if (!filled) up = plane(0) + plane(1) * north + plane(2) * east;
      const Vec3 x(north, east, -up);
      if (!seenBy(left, x) || !seenBy(right, x)) continue;
      if (terrainHides(dem, sigma, left.c, x, step_m) || terrainHides(dem, sigma, right.c, x, step_m)) continue;
      ++count.seen;
      if (filled) ++count.filled;
    }
  }
  return count;
}

}  // namespace areomap::products
