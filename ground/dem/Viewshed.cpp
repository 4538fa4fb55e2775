#include "ground/dem/Viewshed.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "firmware_core/camera/CahvInternal.hpp"

namespace areomap::dem {

namespace {

constexpr float kNone = -std::numeric_limits<float>::infinity();

// The working box: the grid and the eye's cell, indices relative to the grid.
struct RingBox {
  int col0, row0, cols, rows;  // first column and row (may be negative), size
  int eye_col, eye_row;
  std::size_t at(int col, int row) const {
    return static_cast<std::size_t>(row - row0) * static_cast<std::size_t>(cols) + static_cast<std::size_t>(col - col0);
  }
  bool holds(int col, int row) const {
    return col >= col0 && row >= row0 && col < col0 + cols && row < row0 + rows;
  }
};

// Linear between the two cells of the inner ring that bracket the ray from the eye to (dx, dy) (offsets
// from the eye's cell, max(|dx|, |dy|) >= 2), of `steepest` (the steepest line of sight up to and over each
// cell).
float innerRing(const RingBox& box, const std::vector<float>& steepest, int dx, int dy, bool widen) {
  const bool along_x = std::abs(dx) >= std::abs(dy);
  const int major = along_x ? dx : dy, minor = along_x ? dy : dx;
  const int n = std::abs(major);
  const int step = major > 0 ? 1 : -1;
  const double f = static_cast<double>(minor) * (n - 1) / n;
  const int lo = static_cast<int>(std::floor(f));
  const double w = f - lo;
  const auto value = [&](int m) {
    const int c = box.eye_col + (along_x ? major - step : m);
    const int r = box.eye_row + (along_x ? m : major - step);
    return steepest[box.at(c, r)];
  };
  const float a = value(lo);
  if (w <= 0.0) return a;
  const float b = value(lo + 1);
  if (widen || a == kNone || b == kNone) return std::max(a, b);
  return static_cast<float>((1.0 - w) * a + w * b);
}

}  // namespace

void horizonFrom(const DemGrid& terrain, const Vec3& eye, std::vector<float>& horizon, bool widen) {
  const double eye_up = -eye.z();
  const int eye_col = static_cast<int>(std::floor((eye.y() - terrain.east0_m) / terrain.cell_m));
  const int eye_row = static_cast<int>(std::floor((terrain.north0_m - eye.x()) / terrain.cell_m));
  RingBox box{std::min(0, eye_col), std::min(0, eye_row), 0, 0, eye_col, eye_row};
  box.cols = std::max(terrain.cols - 1, eye_col) - box.col0 + 1;
  box.rows = std::max(terrain.rows - 1, eye_row) - box.row0 + 1;
  horizon.assign(static_cast<std::size_t>(terrain.cols) * terrain.rows, kNone);
  // Per box cell: the steepest slope (rise over horizontal distance from the eye) of the lines of sight
  // over the cells up to it and over it.
  std::vector<float> steepest(static_cast<std::size_t>(box.cols) * box.rows, kNone);
  const int rings = std::max({eye_col - box.col0, box.col0 + box.cols - 1 - eye_col, eye_row - box.row0,
                              box.row0 + box.rows - 1 - eye_row});
  const auto visit = [&](int dx, int dy, int ring) {
    const int col = eye_col + dx, row = eye_row + dy;
    if (!box.holds(col, row)) return;
    const float before = ring >= 2 ? innerRing(box, steepest, dx, dy, widen) : kNone;
    const bool in_grid = col >= 0 && row >= 0 && col < terrain.cols && row < terrain.rows;
    float own = kNone;
    double dist = 0.0;
    if (in_grid) {
      dist = std::hypot(terrain.northOfRow(row) - eye.x(), terrain.eastOfCol(col) - eye.y());
      const float z = terrain.at(col, row);
      if (z != terrain.nodata && std::isfinite(z) && dist > 0.0) own = static_cast<float>((z - eye_up) / dist);
      if (before != kNone) horizon[static_cast<std::size_t>(row) * terrain.cols + col] =
          static_cast<float>(eye_up + before * dist);
    }
    steepest[box.at(col, row)] = std::max(before, own);
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
  for (int ring = 1; ring <= rings; ++ring) ringCells(ring, [&](int dx, int dy) { visit(dx, dy, ring); });
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
