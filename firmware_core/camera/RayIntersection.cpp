#include "firmware_core/camera/RayIntersection.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>  // fixed-size 3x3 eigen solver (no heap)

#include "firmware_core/base/Solve3.hpp"

namespace areomap {

namespace {

constexpr int32_t kMaxGaussNewtonIterations = 10;
constexpr double kStepToleranceM = 1e-9;
constexpr double kMinRefinedRayAngleRad = 1e-5;  // intersectPixels: rays closer to parallel do not intersect
constexpr double kJacobianStepM = 1e-6;          // central-difference step (relative to the range)

// The stacked pixels of up to kMaxIntersectionViews views and their Jacobian: fixed storage (the maximum
// size is a template argument), only the first 2 * count rows in use.
using ViewsVec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 2 * kMaxIntersectionViews, 1>;
using ViewsJac = Eigen::Matrix<double, Eigen::Dynamic, 3, 0, 2 * kMaxIntersectionViews, 3>;

Status projectAll(const CameraModel* const* models, int32_t n, const Vec3& p, ViewsVec& uv) {
  uv.resize(2 * n);
  for (int32_t i = 0; i < n; ++i) {
    Vec2 a;
    const Status s = project(*models[i], p, a);
    if (!ok(s)) return s;
    uv(2 * i) = a.x();
    uv(2 * i + 1) = a.y();
  }
  return Status::kOk;
}

// The point and its six central-difference neighbours (p + h e_k, p - h e_k for k = 0, 1, 2, in that
// order) projected into every view, each view's seven at once (projectPoints). The first failing status
// in the order of a view loop per point (p, then p + h e_0, p - h e_0, ...) is returned, as
// projectAll point after point would; else `uv` at p and column k of `j` from the pair k.
Status projectStencil(const CameraModel* const* models, int32_t n, const Vec3& p, double h, ViewsVec& uv,
                      ViewsJac& j) {
  constexpr int32_t kStencil = 7;
  Vec3 points[kStencil] = {p, p, p, p, p, p, p};
  for (int32_t k = 0; k < 3; ++k) {
    points[1 + 2 * k](k) += h;
    points[2 + 2 * k](k) -= h;
  }
  Vec2 px[kMaxIntersectionViews][kStencil];
  Status st[kMaxIntersectionViews][kStencil];
  for (int32_t i = 0; i < n; ++i) projectPoints(*models[i], points, kStencil, px[i], st[i]);
  for (int32_t q = 0; q < kStencil; ++q) {
    for (int32_t i = 0; i < n; ++i) {
      if (!ok(st[i][q])) return st[i][q];
    }
  }
  uv.resize(2 * n);
  for (int32_t i = 0; i < n; ++i) {
    uv.segment<2>(2 * i) = px[i][0];
    for (int32_t k = 0; k < 3; ++k) j.block<2, 1>(2 * i, k) = (px[i][1 + 2 * k] - px[i][2 + 2 * k]) / (2.0 * h);
  }
  return Status::kOk;
}

// Gauss-Newton on the reprojection error of `n` observations from `p`; `j` and `uv` at the solution.
// `origin` (the first ray's) sets the scale of the derivatives' step.
Status refineIntersection(const CameraModel* const* models, int32_t n, const ViewsVec& obs,
                          const Vec3& origin, Vec3& p, ViewsJac& j, ViewsVec& uv) {
  j.resize(2 * n, 3);
  for (int32_t it = 0; it < kMaxGaussNewtonIterations; ++it) {
    const double h = kJacobianStepM * std::max(1.0, (p - origin).norm());
    const Status s = projectStencil(models, n, p, h, uv, j);
    if (!ok(s)) return s;
    const Mat3 normal = j.transpose() * j;
    const Vec3 gradient = j.transpose() * (obs - uv);
    const Vec3 step = ldltSolve3(normal, gradient);  // normal.ldlt().solve(gradient)
    if (!step.allFinite()) return Status::kNotFinite;
    p += step;
    if (step.norm() < kStepToleranceM) break;
  }
  return projectAll(models, n, p, uv);
}

}  // namespace

Status closestApproach(const Vec3& origin1, const Vec3& direction1, const Vec3& origin2,
                       const Vec3& direction2, double min_sin2, Vec3& midpoint, double& miss_m) {
  // Closest points o1 + t1 d1, o2 + t2 d2 (unit directions).
  const Vec3 w = origin1 - origin2;
  const double b = direction1.dot(direction2);
  const double d = direction1.dot(w);
  const double e = direction2.dot(w);
  const double denom = 1.0 - b * b;
  if (denom < min_sin2) return Status::kDegenerate;
  const double t1 = (b * e - d) / denom;
  const double t2 = (e - b * d) / denom;
  if (!(t1 > 0.0) || !(t2 > 0.0)) return Status::kBehindCamera;
  const Vec3 p1 = origin1 + t1 * direction1;
  const Vec3 p2 = origin2 + t2 * direction2;
  midpoint = 0.5 * (p1 + p2);
  miss_m = (p1 - p2).norm();
  return Status::kOk;
}

Status triangulateMidpoint(const CameraModel& left, const CameraModel& right, const Vec2& left_px,
                           const Vec2& right_px, Vec3& point, double& miss_m) {
  Vec3 o1, d1, o2, d2;
  Status s = unproject(left, left_px, o1, d1);
  if (!ok(s)) return s;
  s = unproject(right, right_px, o2, d2);
  if (!ok(s)) return s;
  return closestApproach(o1, d1, o2, d2, kMinMidpointRaySin2, point, miss_m);
}

Status intersectRays(const Vec3* origins, const Vec3* directions, int32_t count, Vec3& point) {
  if (count < 2) {
    return Status::kDegenerate;
  }
  Mat3 a = Mat3::Zero();
  Vec3 b = Vec3::Zero();
  for (int32_t i = 0; i < count; ++i) {
    Mat3 proj;
    proj.noalias() = Mat3::Identity() - directions[i] * directions[i].transpose();
    a += proj;
    b.noalias() += proj * origins[i];
  }
  Eigen::SelfAdjointEigenSolver<Mat3> eig(a);
  const Vec3 ev = eig.eigenvalues();
  // Two parallel rays give an eigenvalue ~0 along the ray; 1e-8 ~ rays 0.1 mrad apart.
  constexpr double kMinEigen = 1e-8;
  if (!(ev(0) > kMinEigen * ev(2))) {
    return Status::kDegenerate;
  }
  point.noalias() = eig.eigenvectors() * (eig.eigenvectors().transpose() * b).cwiseQuotient(ev);
  if (!point.allFinite()) {
    return Status::kNotFinite;
  }
  for (int32_t i = 0; i < count; ++i) {
    if ((point - origins[i]).dot(directions[i]) <= 0.0) {
      return Status::kBehindCamera;
    }
  }
  return Status::kOk;
}

Status intersectPixels(const CameraModel* const* models, const Vec2* pixels, int32_t count,
                       PixelIntersection& out) {
  if (count < 2 || count > kMaxIntersectionViews) return Status::kInvalidArgument;
  Vec3 o1, d1, o2, d2;
  Status s = unproject(*models[0], pixels[0], o1, d1);
  if (ok(s)) s = unproject(*models[1], pixels[1], o2, d2);
  if (!ok(s)) return s;
  Vec3 p;
  double miss_m = 0.0;
  s = closestApproach(o1, d1, o2, d2, kMinRefinedRayAngleRad * kMinRefinedRayAngleRad, p, miss_m);
  if (!ok(s)) return s;
  ViewsVec obs(2 * count);
  for (int32_t i = 0; i < count; ++i) obs.segment<2>(2 * i) = pixels[i];
  ViewsJac j;
  ViewsVec uv;
  s = refineIntersection(models, count, obs, o1, p, j, uv);
  if (!ok(s)) return s;
  out.point_m = p;
  out.normal = j.transpose() * j;
  for (int32_t i = 0; i < count; ++i)
    out.residual_px[i] = (obs.segment<2>(2 * i) - uv.segment<2>(2 * i)).norm();
  out.rms_px = std::sqrt((obs - uv).squaredNorm() / (2.0 * count));
  return Status::kOk;
}

}  // namespace areomap
