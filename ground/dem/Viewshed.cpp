#include "ground/dem/Viewshed.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "firmware_core/camera/CahvInternal.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/cli/Parallel.hpp"

namespace areomap::dem {

namespace {

constexpr float kNone = -std::numeric_limits<float>::infinity();

// The place of the cell (dx, dy) of ring `ring` (max(|dx|, |dy|) = ring >= 1, offsets from the eye's cell)
// in that ring's 8 ring values: the top side, the bottom side, then the left and right sides without their
// corners.
inline std::size_t ringIndex(int dx, int dy, int ring) {
  if (dy == -ring) return static_cast<std::size_t>(dx + ring);
  if (dy == ring) return static_cast<std::size_t>(3 * ring + 1 + dx);
  if (dx == -ring) return static_cast<std::size_t>(5 * ring + 1 + dy);
  return static_cast<std::size_t>(7 * ring + dy);
}

// Linear between the two cells of the inner ring that bracket the ray from the eye to (dx, dy) (offsets
// from the eye's cell, max(|dx|, |dy|) >= 2), of `inner` (that ring's steepest line of sight up to and
// over each cell).
float innerRing(const std::vector<float>& inner, int dx, int dy, bool widen) {
  const bool along_x = std::abs(dx) >= std::abs(dy);
  const int major = along_x ? dx : dy, minor = along_x ? dy : dx;
  const int n = std::abs(major);
  const int step = major > 0 ? 1 : -1;
  const double f = static_cast<double>(minor) * (n - 1) / n;
  const int lo = static_cast<int>(std::floor(f));
  const double w = f - lo;
  const auto value = [&](int m) {
    return along_x ? inner[ringIndex(major - step, m, n - 1)] : inner[ringIndex(m, major - step, n - 1)];
  };
  const float a = value(lo);
  if (w <= 0.0) return a;
  const float b = value(lo + 1);
  if (widen || a == kNone || b == kNone) return std::max(a, b);
  return static_cast<float>((1.0 - w) * a + w * b);
}

}  // namespace

void horizonFrom(const DemGrid& terrain, const Vec3& eye, std::vector<float>& horizon, bool widen) {
  horizonFrom(terrain, eye, GridWindow{0, 0, terrain.cols, terrain.rows}, horizon, widen);
}

void horizonFrom(const DemGrid& terrain, const Vec3& eye, const GridWindow& window,
                 std::vector<float>& horizon, bool widen) {
  const double eye_up = -eye.z();
  const int eye_col = static_cast<int>(std::floor((eye.y() - terrain.east0_m) / terrain.cell_m));
  const int eye_row = static_cast<int>(std::floor((terrain.north0_m - eye.x()) / terrain.cell_m));
  horizon.assign(
      static_cast<std::size_t>(std::max(0, window.cols)) * static_cast<std::size_t>(std::max(0, window.rows)),
      kNone);
  // The window's cells in the grid: c0 .. c1, r0 .. r1.
  const int c0 = std::max(0, window.col0), r0 = std::max(0, window.row0);
  const int c1 = std::min(terrain.cols, window.col0 + window.cols) - 1;
  const int r1 = std::min(terrain.rows, window.row0 + window.rows) - 1;
  if (c1 < c0 || r1 < r0) return;
  // The box of the window and the eye holds every cell between the eye and a window cell, and the two
  // inner-ring cells that bracket its line of sight: the window's values need no cell beyond it.
  // (Indices relative to the grid; its first column and row may be negative.)
  GridWindow box{std::min(c0, eye_col), std::min(r0, eye_row), 0, 0};
  box.cols = std::max(c1, eye_col) - box.col0 + 1;
  box.rows = std::max(r1, eye_row) - box.row0 + 1;
  // Per cell of the last ring and of this one: the steepest slope (rise over horizontal distance from the
  // eye) of the lines of sight over the cells up to it and over it (a ring only reads the one inside it).
  std::vector<float> inner, outer;
  const int rings = std::max({eye_col - box.col0, box.col0 + box.cols - 1 - eye_col, eye_row - box.row0,
                              box.row0 + box.rows - 1 - eye_row});
  const auto visit = [&](int dx, int dy, int ring) {
    const int col = eye_col + dx, row = eye_row + dy;
    if (!box.holds(col, row)) return;
    const float before = ring >= 2 ? innerRing(inner, dx, dy, widen) : kNone;
    const bool in_grid = col >= 0 && row >= 0 && col < terrain.cols && row < terrain.rows;
    float own = kNone;
    double dist = 0.0;
    if (in_grid) {
      dist = std::hypot(terrain.northOfRow(row) - eye.x(), terrain.eastOfCol(col) - eye.y());
      const float z = terrain.at(col, row);
      if (z != terrain.nodata && std::isfinite(z) && dist > 0.0) own = static_cast<float>((z - eye_up) / dist);
      if (before != kNone && window.holds(col, row))
        horizon[window.at(col, row)] = static_cast<float>(eye_up + before * dist);
    }
    outer[ringIndex(dx, dy, ring)] = std::max(before, own);
  };
  const auto ringCells = [](int ring, const auto& f) {
    for (int d = -ring; d <= ring; ++d) {
      f(d, -ring);
      f(d, ring);
    }
    for (int d = -ring + 1; d <= ring - 1; ++d) {
      f(-ring, d);
      f(ring, d);
    }
  };
  for (int ring = 1; ring <= rings; ++ring) {
    outer.assign(8 * static_cast<std::size_t>(ring), kNone);  // cells beyond the box stay without a value
    ringCells(ring, [&](int dx, int dy) { visit(dx, dy, ring); });
    inner.swap(outer);
  }
}

void forEachHorizon(const DemGrid& terrain, const std::vector<Vec3>& eyes,
                    const std::vector<GridWindow>& windows, bool widen,
                    const std::function<void(std::size_t, const std::vector<float>&)>& use) {
  std::size_t bytes = sizeof(float);
  for (const GridWindow& w : windows)
    bytes = std::max(bytes, static_cast<std::size_t>(std::max(0, w.cols)) *
                                static_cast<std::size_t>(std::max(0, w.rows)) * sizeof(float));
  const int threads = static_cast<int>(std::clamp<std::size_t>(
      static_cast<std::size_t>(cli::threadCount()), 1, std::max<std::size_t>(1, kMaxHorizonBytes / bytes)));
  const std::size_t n = std::min(eyes.size(), windows.size());
  cli::orderedFor(
      n, threads,
      [&](std::size_t k) {
        std::vector<float> horizon;
        horizonFrom(terrain, eyes[k], windows[k], horizon, widen);
        return horizon;
      },
      [&](std::size_t k, std::vector<float> horizon) { use(k, horizon); });
  cli::releaseFreedMemory();  // the horizons were freed on the threads' heaps
}

ImageCone imageCone(const CameraModel& m) {
  ImageCone cone;
  cone.axis = m.a.normalized();
  const CahvInternal internal = cahvInternal(m);
  cone.px_per_rad = std::max(internal.hs_px, internal.vs_px);
  const double w = m.width - 1, h = m.height - 1;
  double min_cos = 1.0;
  for (const Vec2& p : {Vec2(0, 0), Vec2(w, 0), Vec2(0, h), Vec2(w, h), Vec2(0.5 * w, 0), Vec2(0.5 * w, h),
                        Vec2(0, 0.5 * h), Vec2(w, 0.5 * h)}) {
    Vec3 origin, ray;
    if (unproject(m, p, origin, ray) != Status::kOk) return ImageCone{cone.axis, -1.0, cone.px_per_rad};  // no rejection
    min_cos = std::min(min_cos, ray.normalized().dot(cone.axis));
  }
  // A margin of about a degree: the border between these points bulges out with the distortion.
  cone.min_cos = std::cos(std::min(M_PI, std::acos(std::clamp(min_cos, -1.0, 1.0)) + 0.02));
  return cone;
}

bool imageSees(const CameraModel& m, const ImageCone& cone, const Vec3& x) {
  const Vec3 d = x - m.c;
  const double dist = d.norm();
  if (!(dist > 0.0) || d.dot(cone.axis) < cone.min_cos * dist) return false;
  Vec2 px;
  if (project(m, x, px) != Status::kOk) return false;
  if (px.x() < -0.5 || px.y() < -0.5 || px.x() > m.width - 0.5 || px.y() > m.height - 0.5) return false;
  Vec3 origin, ray;
  if (unproject(m, px, origin, ray) != Status::kOk) return false;
  const Vec3 to = x - origin;
  const double len = to.norm();
  if (!(to.dot(ray) > 0.0) || !(len > 0.0)) return false;
  return to.cross(ray).norm() / len * cone.px_per_rad < 0.5;
}

}  // namespace areomap::dem
