// Whether a block of points can lie inside a camera's cone of view, from the block's bounds alone: lets a
// per-point cone test (the orthoimage's sources, the truth check's cameras) skip the blocks wholly outside
// a cone and take whole the blocks wholly inside it. Conservative: a relative margin far above the
// rounding of the per-point tests, so that a block called outside holds no point such a test accepts.
#pragma once

#include "firmware_core/base/EigenTypes.hpp"

namespace areomap::ortho {

// The bounds of a block of points in the site frame (down = +Z).
struct PointBounds {
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  void add(const Vec3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  bool empty() const { return !(lo.x() <= hi.x()); }
};

inline constexpr int kConeOutside = -1, kConeAcross = 0, kConeInside = 1;

// Where the block lies against the cone of points x with (x - eye) . axis > 0 and
// ((x - eye) . axis)^2 >= cos2 |x - eye|^2 (cos2 > 0: the squared cosine of its half-angle): kConeOutside
// (no point of the block inside), kConeInside (every point inside), or kConeAcross (across its edge, or
// too near it to tell).
int blockAgainstCone(const PointBounds& b, const Vec3& eye, const Vec3& axis, double cos2);

}  // namespace areomap::ortho
