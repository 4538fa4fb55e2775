// Space intersection of pixel rays, for the rover and the ground alike (paper §3.4 coarse DEM, §3.5 method 2,
// §4.1 triangulation): the closest approach of two rays, the midpoint of two pixels' rays, the
// least-squares point of several rays, and the point that minimises the reprojection error of up to
// kMaxIntersectionViews pixels. Heap-free, no exceptions: fixed storage only.
#pragma once

#include <cstdint>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/Status.hpp"
#include "firmware_core/camera/CameraModel.hpp"

namespace areomap {

// Closest approach of the rays origin1 + t1 direction1 and origin2 + t2 direction2 (unit directions):
// `midpoint` is the middle of the shortest segment between them and `miss_m` its length. kDegenerate when
// 1 - (d1 . d2)^2, the squared sine of the angle between the rays, is below `min_sin2` (nearly parallel);
// kBehindCamera when the segment does not lie ahead of both origins (t1 > 0 and t2 > 0).
[[nodiscard]] Status closestApproach(const Vec3& origin1, const Vec3& direction1, const Vec3& origin2,
                                     const Vec3& direction2, double min_sin2, Vec3& midpoint, double& miss_m);

// The squared sine below which triangulateMidpoint calls two rays parallel: 1 µrad apart.
inline constexpr double kMinMidpointRaySin2 = 1e-12;

// Midpoint of the shortest segment between the rays of a left and a right pixel (closestApproach with
// kMinMidpointRaySin2). `miss_m` is that segment's length. kDegenerate for parallel rays, kBehindCamera
// when the point is behind either camera; unproject's status when a pixel has no ray.
[[nodiscard]] Status triangulateMidpoint(const CameraModel& left, const CameraModel& right,
                                         const Vec2& left_px, const Vec2& right_px, Vec3& point,
                                         double& miss_m);

// Multi-ray intersection of `count` rays (centre, unit direction): the point minimising the sum of squared
// perpendicular distances. kDegenerate when the rays are (nearly) parallel, kBehindCamera when the point
// lies behind one of the origins.
[[nodiscard]] Status intersectRays(const Vec3* origins, const Vec3* directions, int32_t count, Vec3& point);

// Most views intersectPixels takes (the rover's capacity of observations per point).
inline constexpr int32_t kMaxIntersectionViews = kMaxObsPerPoint;

struct PixelIntersection {
  Vec3 point_m = Vec3::Zero();
  // J^T J of the reprojection error at the point (J = d pixels / d point, px/m): the point's covariance is
  // sigma_px^2 (J^T J)^-1.
  Mat3 normal = Mat3::Zero();
  double residual_px[kMaxIntersectionViews] = {};  // |pixel i - projection of point_m| per view
  double rms_px = 0.0;                             // RMS per coordinate over all views
};

// Least-squares intersection of the rays of `count` pixels (2 <= count <= kMaxIntersectionViews) in their
// models: from the closest approach of the first two rays (rays under 10 µrad apart do not intersect), at
// most 10 Gauss-Newton steps on every reprojection error with central-difference derivatives.
// kInvalidArgument for a bad count; kDegenerate, kBehindCamera or a projection's status otherwise.
[[nodiscard]] Status intersectPixels(const CameraModel* const* models, const Vec2* pixels, int32_t count,
                                     PixelIntersection& out);

}  // namespace areomap
