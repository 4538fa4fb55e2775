#include "ground/dem/DemSeen.hpp"

#include <cmath>

#include "ground/dem/Viewshed.hpp"

namespace areomap::dem {

namespace {

// An occluder must rise this many of its sigmas above a line of sight to hide what lies behind (the DEM's
// own noise hides nothing).
constexpr double kSeenSigmas = 2.0;

bool filled(const DemGrid& g, std::size_t i) {
  const float v = g.values[i];
  return v != g.nodata && std::isfinite(v);
}

// The measured cells of `dem`, each lowered by kSeenSigmas of its sigma; every other cell nodata.
DemGrid occluders(const KrigingResult& dem, const std::vector<uint8_t>& measured) {
  DemGrid o = dem.elevation;
  for (std::size_t i = 0; i < o.values.size(); ++i) {
    if (!measured[i] || !filled(dem.elevation, i)) {
      o.values[i] = o.nodata;
      continue;
    }
    const float s = dem.sigma.values[i];
    o.values[i] -= static_cast<float>(kSeenSigmas * (filled(dem.sigma, i) ? s : 0.0f));
  }
  return o;
}

}  // namespace

std::vector<uint8_t> measuredCells(const std::vector<DemPoint>& bins, const DemGrid& grid) {
  std::vector<uint8_t> measured(static_cast<std::size_t>(grid.cols) * grid.rows, 0);
  for (const DemPoint& p : bins) {
    const double col = std::floor((p.east_m - grid.east0_m) / grid.cell_m);
    const double row = std::floor((grid.north0_m - p.north_m) / grid.cell_m);
    if (col >= 0 && row >= 0 && col < grid.cols && row < grid.rows)
      measured[static_cast<std::size_t>(row) * grid.cols + static_cast<std::size_t>(col)] = 1;
  }
  return measured;
}

DemSeen classifyDemCells(KrigingResult& dem, const std::vector<uint8_t>& measured,
                         const std::vector<CameraModel>& cameras) {
  DemGrid& z = dem.elevation;
  const std::size_t n = z.values.size();
  DemSeen out;
  out.classes.assign(n, kCellUnseen);
  for (std::size_t i = 0; i < n; ++i) {
    if (!filled(z, i)) continue;
    out.classes[i] = measured[i] ? kCellMeasured : cameras.empty() ? kCellInterpolated : kCellUnseen;
  }
  if (!cameras.empty()) {
    const DemGrid hiding = occluders(dem, measured);
    std::vector<float> horizon;
    for (const CameraModel& camera : cameras) {
      horizonFrom(hiding, camera.c, horizon, true);
      const ImageCone cone = imageCone(camera);
      for (int row = 0; row < z.rows; ++row) {
        for (int col = 0; col < z.cols; ++col) {
          const std::size_t i = static_cast<std::size_t>(row) * z.cols + col;
          if (out.classes[i] != kCellUnseen || !filled(z, i)) continue;
          if (z.values[i] < horizon[i]) continue;
          if (imageSees(camera, cone, Vec3(z.northOfRow(row), z.eastOfCol(col), -z.values[i])))
            out.classes[i] = kCellInterpolated;
        }
      }
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (out.classes[i] == kCellMeasured) ++out.measured;
    if (out.classes[i] == kCellInterpolated) ++out.interpolated;
    if (out.classes[i] != kCellUnseen || !filled(z, i)) continue;
    ++out.emptied;
    z.values[i] = z.nodata;
    dem.sigma.values[i] = dem.sigma.nodata;
  }
  return out;
}

}  // namespace areomap::dem
