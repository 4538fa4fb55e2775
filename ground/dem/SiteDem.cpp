#include "ground/dem/SiteDem.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>

#include "ground/cli/Cli.hpp"
#include "ground/cli/Parallel.hpp"
#include "ground/dem/BinnedCloud.hpp"
#include "ground/dem/EquiParallax.hpp"

namespace areomap::dem {

namespace {

// The side of r that std::hypot(dn, de) lies on, -1 or 1, where the squares show it clear of r^2 by far more
// than the rounding of either (a relative 1e-12); 0 about the boundary (and for NaN), where hypot itself
// decides: the same verdicts as hypot's, without a hypot for each of the cloud's points.
int rangeSide(double dn, double de, double r) {
  const double s = dn * dn + de * de, r2 = r * r;
  return s < r2 * (1.0 - 1e-12) ? -1 : s > r2 * (1.0 + 1e-12) ? 1 : 0;
}
bool hypotAtMost(double dn, double de, double r) {
  const int side = rangeSide(dn, de, r);
  return side != 0 ? side < 0 : std::hypot(dn, de) <= r;
}
bool hypotAbove(double dn, double de, double r) {
  const int side = rangeSide(dn, de, r);
  return side != 0 ? side > 0 : std::hypot(dn, de) > r;
}

// The cloud's chunks for threads (forEachChunk): each chunk's part is merged in chunk order afterwards.
constexpr std::size_t kSiteChunk = std::size_t{1} << 20;

// The two corners (south-west, north-east) of the points that `keep` accepts, as points: gridAround of
// them is the grid around those points. Empty when it accepts none; `count` (optional) gets how many it does.
template <class Keep>
std::vector<DemPoint> boundingCorners(const PackedCloud& points, const Keep& keep,
                                      std::size_t* count = nullptr) {
  struct Box {
    double n0 = 1e300, e0 = 1e300, n1 = -1e300, e1 = -1e300;
    std::size_t kept = 0;
  };
  std::vector<Box> boxes(chunkCount(points, kSiteChunk));
  forEachChunk(points, kSiteChunk, [&](std::size_t chunk, std::size_t, const DemPoint& p) {
    if (!keep(p)) return;
    Box& b = boxes[chunk];
    ++b.kept;
    b.n0 = std::min(b.n0, p.north_m);
    b.e0 = std::min(b.e0, p.east_m);
    b.n1 = std::max(b.n1, p.north_m);
    b.e1 = std::max(b.e1, p.east_m);
  });
  std::vector<DemPoint> corners(2);
  corners[0].north_m = corners[0].east_m = 1e300;
  corners[1].north_m = corners[1].east_m = -1e300;
  std::size_t kept = 0;
  for (const Box& b : boxes) {
    kept += b.kept;
    corners[0].north_m = std::min(corners[0].north_m, b.n0);
    corners[0].east_m = std::min(corners[0].east_m, b.e0);
    corners[1].north_m = std::max(corners[1].north_m, b.n1);
    corners[1].east_m = std::max(corners[1].east_m, b.e1);
  }
  if (kept == 0) corners.clear();
  if (count != nullptr) *count = kept;
  return corners;
}

// The points that `keep` accepts, in their order: counted per chunk, then copied into place per chunk.
template <class Keep>
std::vector<DemPoint> pointsWhere(const PackedCloud& points, const Keep& keep) {
  std::vector<std::size_t> first(chunkCount(points, kSiteChunk) + 1, 0);
  forEachChunk(points, kSiteChunk, [&](std::size_t chunk, std::size_t, const DemPoint& p) {
    if (keep(p)) ++first[chunk + 1];
  });
  for (std::size_t c = 1; c < first.size(); ++c) first[c] += first[c - 1];
  std::vector<DemPoint> out(first.back());
  forEachChunk(points, kSiteChunk, [&](std::size_t chunk, std::size_t, const DemPoint& p) {
    if (keep(p)) out[first[chunk]++] = p;
  });
  return out;
}

// The kriging's support rule (KrigingOptions::min_cluster_points) as a progress line, into `log`.
void supportInfo(const std::string& product, const KrigingResult& kr, std::vector<std::string>& log) {
  char b[240];
  std::snprintf(
      b, sizeof b,
      "%s: %lld binned points in clusters of fewer than %d (farther than %.3f m from the rest): their %lld "
      "cells left empty",
      product.c_str(), kr.isolated_points, kr.min_cluster_points, kr.max_gap_m, kr.cells_unsupported);
  log.emplace_back(b);
}

// The cells of `kr` classified and the unseen ones emptied (DemSeen.hpp), said in `log`.
DemSeen seenCells(const std::string& product, KrigingResult& kr, const BinnedCloud& binned,
                  const std::vector<CameraModel>& cameras, std::vector<std::string>& log) {
  const auto start = std::chrono::steady_clock::now();
  DemSeen seen = classifyDemCells(kr, measuredCells(binned.points, kr.elevation), cameras);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  char b[240];
  std::snprintf(b, sizeof b,
                "%s: %lld cells measured, %lld interpolated, %lld kriged cells no camera sees left empty (%.1f s)",
                product.c_str(), seen.measured, seen.interpolated, seen.emptied, seconds);
  log.emplace_back(b);
  return seen;
}

// One DEM as made on its own thread: the kriging with its classes, or why it failed, and its progress
// lines (printed once both DEMs are made, the DEM's first).
struct MadeDem {
  std::optional<KrigingResult> kriged;
  DemSeen seen;
  std::vector<std::string> log;
  std::string failure;
};

}  // namespace

double autoDemCell(double extent_m) {
  const double cells = 2000.0;
  const double c = std::max(0.02, extent_m / cells);
  for (double nice : {0.02, 0.025, 0.05, 0.1, 0.2, 0.25, 0.5, 1.0}) {
    if (nice >= c) return nice;
  }
  return 1.0;
}

SiteDem makeSiteDem(PackedCloud pts, const SiteDemOptions& o) {
  SiteDem out;
  const auto warn = [&](const std::string& text) {
    cli::warn(text);
    out.warnings.push_back(text);
  };
  if (pts.empty()) return out;
  const Vec3& g = o.gimbal_site_m;
  // The grid covers the points within max_range_m (those beyond only support it).
  const auto in_range = [&](double north_m, double east_m) {
    return hypotAtMost(north_m - g.x(), east_m - g.y(), o.max_range_m);
  };
  const auto in_range_point = [&](const DemPoint& p) { return in_range(p.north_m, p.east_m); };
  std::vector<DemPoint> box = boundingCorners(pts, in_range_point);
  if (box.empty()) box = boundingCorners(pts, [](const DemPoint&) { return true; });  // all beyond it
  double extent = 0;
  for (const DemPoint& c : box) {
    extent = std::max({extent, std::fabs(c.north_m - g.x()), std::fabs(c.east_m - g.y())});
  }
  const double cell = o.cell_m > 0 ? o.cell_m : autoDemCell(2 * extent);
  DemGrid grid = gridAround(box, cell);
  const auto all = [](const DemPoint&) { return true; };
  // dem.tif's bins finished before the near-rover DEM's are summed: less held beside the cloud.
  const BinnedCloud binned =
      finishBins(sumBins(pts, grid, all, o.correlation_px), grid.cell_m, o.correlation_px);
  out.points_binned = binned.binned_points;
  {
    char b[200];
    std::snprintf(
        b, sizeof b,
        "DEM noise: %.3f of the points' variance is shared by a pair's cells, two pairs' errors in one "
        "cell correlated by %.2f (from %lld bins seen by two pairs)",
        binned.shared_noise_fraction, binned.common_error_correlation, binned.overlap_bins);
    cli::info(b);
  }
  EquiParallaxOptions eo;
  eo.centre_north_m = g.x();
  eo.centre_east_m = g.y();
  eo.centre_up_m = -g.z();
  eo.seam_m = o.seam_m;
  std::vector<DemPoint> far = pointsWhere(pts, [&](const DemPoint& p) {
    return hypotAbove(p.north_m - eo.centre_north_m, p.east_m - eo.centre_east_m,
                      eo.seam_m - eo.blend_m - 1.0);
  });
  // The finer DEM near the rover (DESIGN.md fixes dem.tif as one grid): when dem.tif is coarser than
  // near_cell_m, the points within near_range_m are kriged again at near_cell_m into dem_near.tif. Its
  // points are summed into its cells here, so that the cloud is freed before the bins are finished and
  // before any kriging.
  std::optional<DemGrid> near_grid;
  std::optional<BinSums> near_sums;
  if (o.near_cell_m > 0 && o.near_range_m > 0 && cell > o.near_cell_m * 1.001) {
    const double reach = o.near_range_m + 0.5;  // points just beyond the edge support it
    const auto is_near = [&](const DemPoint& p) {
      return std::fabs(p.north_m - g.x()) <= reach && std::fabs(p.east_m - g.y()) <= reach;
    };
    std::size_t count = 0;
    const std::vector<DemPoint> corners = boundingCorners(pts, is_near, &count);
    if (count >= 16) {
      try {
        near_grid = gridAround(corners, o.near_cell_m);
        near_sums = sumBins(pts, *near_grid, is_near, o.correlation_px);
      } catch (const std::exception& e) {
        warn(std::string("near-rover DEM not made: ") + e.what());
      }
    }
  }
  pts.release();
  BinnedCloud near_binned;
  if (near_sums) {
    near_binned = finishBins(std::move(*near_sums), near_grid->cell_m, o.correlation_px);
    near_sums.reset();
  }
  // dem.tif (kriging, the far range, the range limit, its classes) and dem_near.tif do not depend on each
  // other: made side by side, so that the serial parts of one overlap the other's work. The near-rover DEM
  // is kept only when dem.tif is made.
  MadeDem made[2];
  cli::parallelFor(near_grid ? 2 : 1, 0, [&](std::size_t task) {
    MadeDem& m = made[task];
    try {
      if (task == 1) {
        KrigingResult nk = krigeDem(near_binned.points, *near_grid,
                                    binnedKrigingOptions(near_binned, *near_grid, o.correlation_px, o.shared_error));
        supportInfo("dem_near.tif", nk, m.log);
        m.seen = seenCells("dem_near.tif", nk, near_binned, o.cameras, m.log);
        m.kriged = std::move(nk);
        return;
      }
      // The far range first: the cells whose kriged value the blend replaces whole, and those beyond
      // max_range_m, which are emptied, are not kriged.
      std::optional<DemGrid> far_dem;
      DemGrid far_sigma;
      std::vector<uint8_t> wanted(static_cast<std::size_t>(grid.cols) * grid.rows, 1);
      if (!far.empty()) {
        far_dem = equiParallaxDem(far, grid, eo, &far_sigma);
        wanted = cellsBlendKeeps(*far_dem, eo);
      }
      std::vector<DemPoint>().swap(far);
      for (int r = 0; r < grid.rows; ++r) {
        for (int c = 0; c < grid.cols; ++c) {
          if (!in_range(grid.northOfRow(r), grid.eastOfCol(c)))
            wanted[static_cast<std::size_t>(r) * grid.cols + c] = 0;
        }
      }
      KrigingOptions ko = binnedKrigingOptions(binned, grid, o.correlation_px, o.shared_error);
      ko.cells = &wanted;
      KrigingResult kr = krigeDem(binned.points, grid, ko);
      supportInfo("dem.tif", kr, m.log);
      if (far_dem) blendFarRange(kr, *far_dem, &far_sigma, eo);
      for (int r = 0; r < grid.rows; ++r) {
        for (int c = 0; c < grid.cols; ++c) {
          if (in_range(grid.northOfRow(r), grid.eastOfCol(c))) continue;
          kr.elevation.at(c, r) = kr.elevation.nodata;
          kr.sigma.at(c, r) = kr.sigma.nodata;
        }
      }
      m.seen = seenCells("dem.tif", kr, binned, o.cameras, m.log);
      m.kriged = std::move(kr);
    } catch (const std::exception& e) {
      m.failure = e.what();
    }
  });
  for (const std::string& line : made[0].log) cli::info(line);
  if (!made[0].failure.empty()) warn("DEM not made: " + made[0].failure);
  out.dem = std::move(made[0].kriged);
  out.dem_seen = std::move(made[0].seen);
  if (out.dem && near_grid) {
    for (const std::string& line : made[1].log) cli::info(line);
    if (!made[1].failure.empty()) warn("near-rover DEM not made: " + made[1].failure);
    out.near = std::move(made[1].kriged);
    out.near_seen = std::move(made[1].seen);
  }
  return out;
}

}  // namespace areomap::dem
