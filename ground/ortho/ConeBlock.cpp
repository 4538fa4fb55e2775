#include "ground/ortho/ConeBlock.hpp"

#include <algorithm>
#include <limits>

namespace areomap::ortho {

int blockAgainstCone(const PointBounds& b, const Vec3& eye, const Vec3& axis, double cos2) {
  double along_lo = std::numeric_limits<double>::infinity(), along_hi = -along_lo, far2 = 0.0, scale = 0.0;
  for (int k = 0; k < 8; ++k) {
    const Vec3 d = Vec3(k & 1 ? b.hi.x() : b.lo.x(), k & 2 ? b.hi.y() : b.lo.y(), k & 4 ? b.hi.z() : b.lo.z()) - eye;
    const double along = d.dot(axis);
    along_lo = std::min(along_lo, along);
    along_hi = std::max(along_hi, along);
    far2 = std::max(far2, d.squaredNorm());
    scale = std::max(scale, d.cwiseAbs().sum());
  }
  const Vec3 nearest = eye.cwiseMax(b.lo).cwiseMin(b.hi);
  const double near2 = (nearest - eye).squaredNorm();
  constexpr double kMargin = 1e-6;
  const double slack = kMargin * scale;
  // Every point's along lies within [along_lo, along_hi] (linear: its extremes are at corners) and its
  // squared distance within [near2, far2].
  if (along_hi + slack <= 0.0) return kConeOutside;
  if ((along_hi + slack) * (along_hi + slack) < cos2 * near2 * (1.0 - kMargin)) return kConeOutside;
  if (along_lo - slack > 0.0 && (along_lo - slack) * (along_lo - slack) >= cos2 * far2 * (1.0 + kMargin))
    return kConeInside;
  return kConeAcross;
}

}  // namespace areomap::ortho
