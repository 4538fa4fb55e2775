#include "firmware_core/adjust/Datum.hpp"

#include <Eigen/SVD>
#include <cmath>

#include "firmware_core/adjust/FastAdjuster.hpp"

namespace areomap {

Mat3 commonRotation(const Mat3* estimated, const Mat3* truth, int32_t count) {
  Mat3 sum = Mat3::Zero();
  for (int32_t i = 0; i < count; ++i) sum.noalias() += truth[i].transpose() * estimated[i];
  const Eigen::JacobiSVD<Mat3> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 d = Mat3::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

TruthErrors truthErrors(const Network& net, const Vec3* true_centres, const Mat3* true_rotations,
                        const Vec3* true_points, const Vec3& gimbal_m, bool aligned, double range_m) {
  Mat3 r = Mat3::Identity();
  if (aligned && net.imageCount() > 0) {
    Mat3 estimated[kMaxImages];
    for (int32_t i = 0; i < net.imageCount(); ++i) estimated[i] = net.image(i).m;
    r = commonRotation(estimated, true_rotations, net.imageCount());
  }
  TruthErrors e;
  double sum_eo = 0.0;
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    const NetImage& im = net.image(i);
    Mat3 m;
    m.noalias() = im.m * r.transpose();
    Vec3 c = gimbal_m;
    c.noalias() += r * (im.centre_m - gimbal_m);
    const double px = eoPixelEquivalent(im.io.f_px, c - true_centres[i], rotationAngle(m, true_rotations[i]), range_m);
    sum_eo += px * px;
  }
  e.eo_px = net.imageCount() > 0 ? std::sqrt(sum_eo / net.imageCount()) : 0.0;
  if (true_points != nullptr) {
    double sum_p = 0.0;
    for (int32_t p = 0; p < net.pointCount(); ++p) {
      if (!net.point(p).solvable || !true_points[p].allFinite()) continue;
      Vec3 x = gimbal_m;
      x.noalias() += r * (net.point(p).xyz_m - gimbal_m);
      sum_p += (x - true_points[p]).squaredNorm();
      ++e.points;
    }
    e.ground_m = e.points > 0 ? std::sqrt(sum_p / e.points) : 0.0;
  }
  return e;
}

}  // namespace areomap
