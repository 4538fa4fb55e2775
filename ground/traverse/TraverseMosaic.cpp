#include "ground/traverse/TraverseMosaic.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace areomap::traverse {

bool sampleRaster(const DemGrid& g, double north_m, double east_m, bool interpolate, double& value) {
  const double fc = (east_m - g.east0_m) / g.cell_m - 0.5;  // column coordinate of cell centres
  const double fr = (g.north0_m - north_m) / g.cell_m - 0.5;
  const int nc = static_cast<int>(std::lround(fc)), nr = static_cast<int>(std::lround(fr));
  if (nc < 0 || nr < 0 || nc >= g.cols || nr >= g.rows) return false;
  const float nearest = g.at(nc, nr);
  if (interpolate) {
    const int c0 = static_cast<int>(std::floor(fc)), r0 = static_cast<int>(std::floor(fr));
    if (c0 >= 0 && r0 >= 0 && c0 + 1 < g.cols && r0 + 1 < g.rows) {
      const float v00 = g.at(c0, r0), v10 = g.at(c0 + 1, r0), v01 = g.at(c0, r0 + 1),
                  v11 = g.at(c0 + 1, r0 + 1);
      if (v00 != g.nodata && v10 != g.nodata && v01 != g.nodata && v11 != g.nodata) {
        const double u = fc - c0, v = fr - r0;
        value = (1 - u) * (1 - v) * v00 + u * (1 - v) * v10 + (1 - u) * v * v01 + u * v * v11;
        return true;
      }
    }
  }
  if (nearest == g.nodata) return false;
  value = nearest;
  return true;
}

RasterDifference differenceNear(const DemGrid& dem, const DemGrid& truth,
                                const std::vector<Eigen::Vector3d>& centres, double radius_m) {
  RasterDifference d;
  double sum = 0.0;
  for (int r = 0; r < dem.rows; ++r) {
    for (int c = 0; c < dem.cols; ++c) {
      const float v = dem.at(c, r);
      if (v == dem.nodata) continue;
      const double n = dem.northOfRow(r), e = dem.eastOfCol(c);
      bool near = false;
      for (const Eigen::Vector3d& p : centres) near = near || std::hypot(n - p.x(), e - p.y()) <= radius_m;
      double t = 0.0;
      if (!near || !sampleRaster(truth, n, e, true, t)) continue;
      sum += (v - t) * (v - t);
      ++d.cells;
    }
  }
  if (d.cells > 0) d.rms_m = std::sqrt(sum / static_cast<double>(d.cells));
  return d;
}

DemGrid traverseGrid(const std::vector<MosaicInput>& inputs, double cell_m) {
  if (!(cell_m > 0.0)) throw std::invalid_argument("traverse mosaic: the cell must be positive");
  double n0 = std::numeric_limits<double>::infinity(), e0 = n0, n1 = -n0, e1 = -n0;
  for (const MosaicInput& in : inputs) {
    if (in.raster == nullptr || in.raster->cols == 0) continue;
    const DemGrid& g = *in.raster;
    const double north[2] = {g.north0_m, g.north0_m - g.rows * g.cell_m};
    const double east[2] = {g.east0_m, g.east0_m + g.cols * g.cell_m};
    for (double n : north) {
      for (double e : east) {
        const Eigen::Vector3d t = in.pose.toTraverse(Eigen::Vector3d(n, e, 0.0));
        n0 = std::min(n0, t.x());
        n1 = std::max(n1, t.x());
        e0 = std::min(e0, t.y());
        e1 = std::max(e1, t.y());
      }
    }
  }
  if (!(n1 > n0) || !(e1 > e0)) throw std::invalid_argument("traverse mosaic: no site raster");
  DemGrid grid;
  grid.cell_m = cell_m;
  grid.east0_m = std::floor(e0 / cell_m) * cell_m;
  grid.north0_m = std::ceil(n1 / cell_m) * cell_m;
  grid.cols = static_cast<int>(std::ceil((e1 - grid.east0_m) / cell_m));
  grid.rows = static_cast<int>(std::ceil((grid.north0_m - n0) / cell_m));
  grid.values.assign(static_cast<std::size_t>(grid.cols) * grid.rows, grid.nodata);
  return grid;
}

Mosaic mosaic(const std::vector<MosaicInput>& inputs, const DemGrid& grid, MosaicKind kind) {
  Mosaic m;
  m.grid = grid;
  m.grid.values.assign(static_cast<std::size_t>(grid.cols) * grid.rows, grid.nodata);
  m.site_of_cell.assign(m.grid.values.size(), -1);
  std::vector<int> order(inputs.size());
  std::vector<double> distance(inputs.size());
  for (int r = 0; r < grid.rows; ++r) {
    const double north = grid.northOfRow(r);
    for (int c = 0; c < grid.cols; ++c) {
      const double east = grid.eastOfCol(c);
      for (std::size_t k = 0; k < inputs.size(); ++k) {
        distance[k] = std::hypot(north - inputs[k].pose.position_m.x(), east - inputs[k].pose.position_m.y());
      }
      std::iota(order.begin(), order.end(), 0);
      std::sort(order.begin(), order.end(), [&](int a, int b) { return distance[a] < distance[b]; });
      for (int k : order) {
        const MosaicInput& in = inputs[static_cast<std::size_t>(k)];
        if (in.raster == nullptr) continue;
        const Eigen::Vector3d s = in.pose.toSite(Eigen::Vector3d(north, east, in.pose.position_m.z()));
        double v = 0.0;
        if (!sampleRaster(*in.raster, s.x(), s.y(), kind != MosaicKind::kGrey, v)) continue;
        if (kind == MosaicKind::kElevation) v -= in.pose.position_m.z();
        if (kind == MosaicKind::kSigma) v = std::sqrt(v * v + in.extra_variance);
        m.grid.at(c, r) = static_cast<float>(v);
        m.site_of_cell[static_cast<std::size_t>(r) * grid.cols + c] = k;
        break;
      }
    }
  }
  return m;
}

}  // namespace areomap::traverse
