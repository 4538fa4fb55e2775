#include "ground/dem/DemSeen.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "ground/cli/Parallel.hpp"
#include "ground/dem/Viewshed.hpp"

namespace areomap::dem {

namespace {

bool filled(const DemGrid& g, std::size_t i) {
  const float v = g.values[i];
  return v != g.nodata && std::isfinite(v);
}

// One camera's view of the measured cells: per bin of `bin` x `bin` pixels the distance from the camera
// centre to the nearest measured cell that projects into it (a z-buffer: the nearest surface is the one
// the image shows); +infinity where none does.
struct MeasuredDepth {
  const CameraModel* camera = nullptr;
  ImageCone cone;
  int bin = 1, cols = 0, rows = 0;
  std::vector<float> depth;
  float at(int u, int v) const {
    return u < 0 || v < 0 || u >= cols || v >= rows ? kNoDepth : depth[static_cast<std::size_t>(v) * cols + u];
  }
  static constexpr float kNoDepth = std::numeric_limits<float>::infinity();
};

// A depth jump between two bins of the window is an occlusion edge when it exceeds this many times the
// ground's spacing per bin (at the line of sight's grazing angle) plus as many cells: rough ground seen at
// a grazing angle steps by more than flat ground does.
constexpr double kJumpSteps = 4.0;

// Bins of about kBinRad of arc: a few pixels of the larger images, so that the cells of the ground at a
// grazing angle fill every bin they cover.
constexpr double kBinRad = 0.0015;

bool projectInto(const MeasuredDepth& d, const Vec3& x, Vec2& bin_px) {
  const Vec3 to = x - d.camera->c;
  const double dist = to.norm();
  if (!(dist > 0.0) || to.dot(d.cone.axis) < d.cone.min_cos * dist) return false;
  Vec2 px;
  if (project(*d.camera, x, px) != Status::kOk) return false;
  if (px.x() < -0.5 || px.y() < -0.5 || px.x() > d.camera->width - 0.5 || px.y() > d.camera->height - 0.5) return false;
  bin_px = (px + Vec2(0.5, 0.5)) / d.bin;
  return true;
}

void splat(MeasuredDepth& d, int u0, int v0, int hu, int hv, float dist) {
  for (int v = std::max(0, v0 - hv); v <= std::min(d.rows - 1, v0 + hv); ++v) {
    for (int u = std::max(0, u0 - hu); u <= std::min(d.cols - 1, u0 + hu); ++u) {
      float& slot = d.depth[static_cast<std::size_t>(v) * d.cols + u];
      slot = std::min(slot, dist);
    }
  }
}

// The lowest of the measured elevations of the cell (col, row) and its four neighbours.
float lowestAround(const DemGrid& z, const std::vector<uint8_t>& measured, int col, int row) {
  float low = z.at(col, row);
  for (const auto& [dc, dr] : {std::pair{1, 0}, std::pair{-1, 0}, std::pair{0, 1}, std::pair{0, -1}}) {
    const int c = col + dc, r = row + dr;
    if (c < 0 || r < 0 || c >= z.cols || r >= z.rows) continue;
    const std::size_t j = static_cast<std::size_t>(r) * z.cols + c;
    if (measured[j] && filled(z, j)) low = std::min(low, z.values[j]);
  }
  return low;
}

// The z-buffer of the measured cells of `z` seen through `camera`: each cell splatted over the bins of its
// footprint grown by half a cell each way (its width across the line of sight, its length along it
// foreshortened by the angle the line of sight makes with the ground), so that a cell the matcher missed
// leaves no hole between its neighbours, and down to its lowest measured neighbour: a step in the DEM
// (a rock's face) covers the pixels between its top and its foot, which no cell of a 2.5-D grid fills.
// footprint false: each cell over the bins of its own square only (and its step down): a buffer that shows
// a surface in a bin only where a measured cell lies in it.
MeasuredDepth measuredDepth(const CameraModel& camera, const DemGrid& z, const std::vector<uint8_t>& measured,
                            bool footprint = true) {
  MeasuredDepth d;
  d.camera = &camera;
  d.cone = imageCone(camera);
  d.bin = std::max(1, static_cast<int>(std::lround(kBinRad * d.cone.px_per_rad)));
  d.cols = (camera.width + d.bin - 1) / d.bin;
  d.rows = (camera.height + d.bin - 1) / d.bin;
  d.depth.assign(static_cast<std::size_t>(d.cols) * d.rows, MeasuredDepth::kNoDepth);
  const double bins_per_rad = d.cone.px_per_rad / d.bin;
  for (int row = 0; row < z.rows; ++row) {
    for (int col = 0; col < z.cols; ++col) {
      const std::size_t i = static_cast<std::size_t>(row) * z.cols + col;
      if (!measured[i] || !filled(z, i)) continue;
      const Vec3 x(z.northOfRow(row), z.eastOfCol(col), -z.values[i]);
      Vec2 b;
      if (!projectInto(d, x, b)) continue;
      const Vec3 to = x - camera.c;
      const float dist = static_cast<float>(to.norm());
      const double across = z.cell_m / dist * bins_per_rad;
      const double along = across * std::fabs(to.z()) / dist;
      const double grow = footprint ? 1.0 : 0.5;
      const int hu = std::min(8, static_cast<int>(grow * across)), hv = std::min(8, static_cast<int>(grow * along));
      splat(d, static_cast<int>(std::floor(b.x())), static_cast<int>(std::floor(b.y())), hu, hv, dist);
      const float low = lowestAround(z, measured, col, row);
      Vec2 foot;
      if (!(z.values[i] - low > 0.5 * z.cell_m) || !projectInto(d, Vec3(x.x(), x.y(), -low), foot)) continue;
      const int steps = std::min(256, static_cast<int>(std::ceil((foot - b).norm())));
      for (int k = 1; k <= steps; ++k) {
        const Vec2 s = b + (foot - b) * (static_cast<double>(k) / steps);
        splat(d, static_cast<int>(std::floor(s.x())), static_cast<int>(std::floor(s.y())), hu, 0, dist);
      }
    }
  }
  return d;
}

// A cell's line of sight in the camera of `d`: its bin (projectInto), its distance, horizontal distance, a
// bin's angle, the ground's spacing per bin at its grazing angle, and the image direction of the vertical
// at the cell, one bin long. False where it does not project or lies straight below the camera.
struct Sight {
  Vec2 bin, down;
  double dist = 0.0, horizontal = 0.0, bin_rad = 0.0, step = 0.0;
};

bool sightOf(const MeasuredDepth& d, const Vec3& x, Sight& s) {
  if (!projectInto(d, x, s.bin)) return false;
  const Vec3 to = x - d.camera->c;
  s.dist = to.norm();
  s.horizontal = std::hypot(to.x(), to.y());
  if (!(s.horizontal > 0.0)) return false;
  const double tan_grazing = to.z() / s.horizontal;  // Z down: the line of sight descends to the cell
  s.bin_rad = d.bin / d.cone.px_per_rad;
  s.step = s.dist * s.bin_rad / std::max(tan_grazing, s.bin_rad);  // ground distance per bin
  Vec2 q;
  const double drop = std::max(0.01, 0.02 * s.dist);
  if (!projectInto(d, x + Vec3(0, 0, drop), q)) q = s.bin + Vec2(0, 1);
  s.down = q - s.bin;
  if (!(s.down.norm() > 1e-9)) s.down = Vec2(0, 1);
  s.down.normalize();
  return true;
}

// Whether the camera of `d` sees the ground of the cell at `x` (its kriged estimate, `sigma_m` its
// sigma): it projects into the image, and along the image's vertical through its projection, within the
// estimate's uncertainty and a few bins, two neighbouring measured bins that straddle the cell's distance
// do not jump (kJumpSteps): a jump is an occlusion edge, the cell lies in the shadow of the nearer surface
// (behind a rock the kriged estimate lies on the lines of sight that graze its top, so the estimate's own
// pixel cannot tell). The window must also show the cell's own distance (to the spacing of the ground's
// samples at that grazing angle) unless it holds no measured bin at all (no evidence either way).
bool depthSees(const MeasuredDepth& d, const Vec3& x, double sigma_m, double cell_m) {
  Sight los;
  if (!sightOf(d, x, los)) return false;
  const Vec2& p = los.bin;
  const Vec2& down = los.down;
  const double dist = los.dist, horizontal = los.horizontal, bin_rad = los.bin_rad, step = los.step;
  const double tolerance = step + cell_m;
  const double estimate_bins = 3.0 * std::max(sigma_m, 0.0) * (horizontal / dist) / dist / bin_rad;
  const int reach = static_cast<int>(std::min(48.0, 3.0 + estimate_bins));
  bool close = false;
  float previous = MeasuredDepth::kNoDepth;
  int previous_k = 0;
  for (int k = -reach; k <= reach; ++k) {
    const Vec2 s = p + down * static_cast<double>(k);
    const float v = d.at(static_cast<int>(std::floor(s.x())), static_cast<int>(std::floor(s.y())));
    if (v == MeasuredDepth::kNoDepth) continue;
    close = close || std::fabs(v - dist) <= tolerance;
    if (previous != MeasuredDepth::kNoDepth && std::min(v, previous) < dist && dist < std::max(v, previous) &&
        std::fabs(v - previous) > kJumpSteps * (k - previous_k) * step + kJumpSteps * cell_m)
      return false;  // a depth jump over the cell: it lies in the shadow of the nearer surface
    previous = v;
    previous_k = k;
  }
  return close || previous == MeasuredDepth::kNoDepth;
}

// Whether the camera of `d` shows, at the projection of the measured cell at `x` (`sigma_m` its height
// sigma), a measured surface nearer than the cell by more than the cell's place along its line of sight can
// be wrong: the cell lies behind what that pixel images (free space: the camera cannot have measured it
// there). The allowance is the ground's spacing per bin at that grazing angle and a cell (the bin's nearest
// cell may lie that much before the cell on seen ground) and three sigmas of two cells' difference along
// the line of sight (a height sigma over the grazing angle's sine).
bool hiddenBehind(const MeasuredDepth& d, const Vec3& x, double sigma_m, double cell_m) {
  Sight s;
  if (!sightOf(d, x, s)) return false;
  const double sine = std::max(std::sqrt(std::max(0.0, s.dist * s.dist - s.horizontal * s.horizontal)) / s.dist, s.bin_rad);
  const double along = std::max(sigma_m, 0.0) / sine;
  const double allowed = s.dist - (s.step + cell_m + 3.0 * std::sqrt(2.0) * along);
  // The bin of the projection and its neighbours along the image's vertical all nearer: a bin that an
  // occlusion edge crosses holds the nearer surface's depth for the farther surface's pixels in it too.
  for (int k = -1; k <= 1; ++k) {
    const Vec2 b = s.bin + s.down * static_cast<double>(k);
    const float v = d.at(static_cast<int>(std::floor(b.x())), static_cast<int>(std::floor(b.y())));
    if (!(v < allowed)) return false;
  }
  return true;
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
    // Every camera's depth buffer, then the rows: a cell is interpolated when any camera sees it, so the
    // cameras' order and the rows' split between threads do not change the classes.
    // Measured cells that every camera holding them shows behind a nearer measured surface (hiddenBehind)
    // are unseen first, and the depth buffers are made without them (once: with none hidden, of every
    // measured cell).
    std::vector<MeasuredDepth> centres(cameras.size());
    cli::parallelFor(cameras.size(), 0,
                     [&](std::size_t k) { centres[k] = measuredDepth(cameras[k], z, measured, false); });
    std::vector<uint8_t> visible = measured;
    std::vector<long long> hidden_rows(static_cast<std::size_t>(z.rows), 0);
    cli::parallelFor(static_cast<std::size_t>(z.rows), 0, [&](std::size_t row_index) {
      const int row = static_cast<int>(row_index);
      for (int col = 0; col < z.cols; ++col) {
        const std::size_t i = static_cast<std::size_t>(row) * z.cols + col;
        if (out.classes[i] != kCellMeasured) continue;
        const Vec3 x(z.northOfRow(row), z.eastOfCol(col), -z.values[i]);
        const double s = filled(dem.sigma, i) ? dem.sigma.values[i] : 0.0;
        bool held = false, seen = false;
        for (const MeasuredDepth& depth : centres) {
          Vec2 p;
          if (!projectInto(depth, x, p) || !imageSees(*depth.camera, depth.cone, x)) continue;
          held = true;
          if (!hiddenBehind(depth, x, s, z.cell_m)) {
            seen = true;
            break;
          }
        }
        if (!held || seen) continue;
        out.classes[i] = kCellUnseen;
        visible[i] = 0;
        ++hidden_rows[row_index];
      }
    });
    for (long long h : hidden_rows) out.hidden += h;
    std::vector<MeasuredDepth>().swap(centres);
    std::vector<MeasuredDepth> depths(cameras.size());
    cli::parallelFor(cameras.size(), 0,
                     [&](std::size_t k) { depths[k] = measuredDepth(cameras[k], z, visible); });
    cli::parallelFor(static_cast<std::size_t>(z.rows), 0, [&](std::size_t row_index) {
      const int row = static_cast<int>(row_index);
      for (int col = 0; col < z.cols; ++col) {
        const std::size_t i = static_cast<std::size_t>(row) * z.cols + col;
        if (out.classes[i] != kCellUnseen || measured[i] || !filled(z, i)) continue;
        const Vec3 x(z.northOfRow(row), z.eastOfCol(col), -z.values[i]);
        const double s = filled(dem.sigma, i) ? dem.sigma.values[i] : 0.0;
        for (const MeasuredDepth& depth : depths) {
          if (!depthSees(depth, x, s, z.cell_m) || !imageSees(*depth.camera, depth.cone, x)) continue;
          out.classes[i] = kCellInterpolated;
          break;
        }
      }
    });
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
