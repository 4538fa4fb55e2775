#include "firmware_core/match/EpipolarSearch.hpp"

#include <cmath>

namespace areomap {
namespace {

constexpr int32_t kAmbiguityDistancePx = 3;

bool inside(const Vec2& p, int32_t w, int32_t h) {
  return p.x() >= 0.0 && p.y() >= 0.0 && p.x() <= w - 1.0 && p.y() <= h - 1.0;
}

void consider(SearchHit& hit, double s, int32_t x, int32_t y) {
  if (s <= kNccInvalid) return;
  if (s > hit.score) {
    const bool far = std::abs(x - hit.x) >= kAmbiguityDistancePx || std::abs(y - hit.y) >= kAmbiguityDistancePx;
    if (far && hit.score > hit.second) hit.second = hit.score;
    hit.score = s;
    hit.x = x;
    hit.y = y;
  } else if (s > hit.second &&
             (std::abs(x - hit.x) >= kAmbiguityDistancePx || std::abs(y - hit.y) >= kAmbiguityDistancePx)) {
    hit.second = s;
  }
}

}  // namespace

Status epipolarCurve(const CameraModel& from, const CameraModel& to, const Vec2& pixel, double min_range_m,
                     double max_range_m, int32_t to_width, int32_t to_height, EpipolarCurve& curve) {
  curve.count = 0;
  if (!(min_range_m > 0.0) || !(max_range_m > min_range_m)) return Status::kInvalidArgument;
  Vec3 origin, direction;
  const Status s = unproject(from, pixel, origin, direction);
  if (!ok(s)) return s;
  // Length of the curve in `to`, from the projections of the two ends (a point behind `to` is skipped by
  // pulling the near end out until it projects, in at most 8 halvings of inverse range).
  const double inv_far = 1.0 / max_range_m;
  double inv_near = 1.0 / min_range_m;
  Vec2 p_far, p_near;
  if (!ok(project(to, origin + direction / inv_far, p_far))) return Status::kBehindCamera;
  bool near_ok = false;
  for (int32_t i = 0; i < 8 && !near_ok; ++i) {
    near_ok = ok(project(to, origin + direction / inv_near, p_near));
    if (!near_ok) inv_near = 0.5 * (inv_near + inv_far);
  }
  if (!near_ok) return Status::kBehindCamera;
  curve.far_px = p_far;
  const double length_px = (p_near - p_far).norm();
  int32_t steps = static_cast<int32_t>(std::ceil(length_px)) + 1;
  if (steps < 2) steps = 2;
  if (steps > kMaxEpipolarSteps) steps = kMaxEpipolarSteps;
  for (int32_t k = 0; k < steps; ++k) {
    const double inv = inv_far + (inv_near - inv_far) * static_cast<double>(k) / (steps - 1);
    Vec2 p;
    if (!ok(project(to, origin + direction / inv, p))) continue;
    if (!inside(p, to_width, to_height)) continue;
    curve.x[curve.count] = static_cast<float>(p.x());
    curve.y[curve.count] = static_cast<float>(p.y());
    ++curve.count;
  }
  return curve.count > 0 ? Status::kOk : Status::kBehindCamera;
}

SearchHit searchAlongCurve(const NccTemplate& t, const ImageView& target, const EpipolarCurve& curve,
                           int32_t band_px) {
  SearchHit hit;
  if (band_px < 0) band_px = 0;
  if (band_px > kMaxEpipolarBandPx) band_px = kMaxEpipolarBandPx;
  int32_t last_x = -1000000, last_y = -1000000;
  for (int32_t k = 0; k < curve.count; ++k) {
    const int32_t cx = static_cast<int32_t>(std::lround(curve.x[k]));
    const int32_t cy = static_cast<int32_t>(std::lround(curve.y[k]));
    if (cx == last_x && cy == last_y) continue;
    last_x = cx;
    last_y = cy;
    // Across the curve: the local normal, rounded to the dominant axis (the curve is close to a line).
    const int32_t k0 = k > 0 ? k - 1 : k;
    const int32_t k1 = k + 1 < curve.count ? k + 1 : k;
    const double dx = curve.x[k1] - curve.x[k0];
    const double dy = curve.y[k1] - curve.y[k0];
    const bool horizontal = std::fabs(dx) >= std::fabs(dy);
    for (int32_t o = -band_px; o <= band_px; ++o) {
      const int32_t x = horizontal ? cx : cx + o;
      const int32_t y = horizontal ? cy + o : cy;
      consider(hit, nccAt(t, target, x, y), x, y);
    }
  }
  return hit;
}

SearchHit searchWindowWarped(const NccTemplate& t, const ImageView& target, int32_t cx, int32_t cy, int32_t radius,
                             const Mat2& a) {
  SearchHit hit;
  if (radius > kInterOffsetSearchRadiusPx) radius = kInterOffsetSearchRadiusPx;
  for (int32_t dy = -radius; dy <= radius; ++dy) {
    for (int32_t dx = -radius; dx <= radius; ++dx) {
      consider(hit, nccWarpedAt(t, target, cx + dx, cy + dy, a), cx + dx, cy + dy);
    }
  }
  return hit;
}

void refinePeakWarped(const NccTemplate& t, const ImageView& image, int32_t bx, int32_t by, double best,
                      const Mat2& a, double& x_px, double& y_px) {
  const double l = nccWarpedAt(t, image, bx - 1, by, a);
  const double r = nccWarpedAt(t, image, bx + 1, by, a);
  const double u = nccWarpedAt(t, image, bx, by - 1, a);
  const double d = nccWarpedAt(t, image, bx, by + 1, a);
  x_px = bx + parabolaOffset(l, best, r);
  y_px = by + parabolaOffset(u, best, d);
}

}  // namespace areomap
