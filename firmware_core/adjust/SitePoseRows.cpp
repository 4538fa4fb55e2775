#include "firmware_core/adjust/SitePoseRows.hpp"

#include <cmath>

namespace areomap {

namespace {

// log map of a rotation through its unit quaternion (accurate near the identity, where the odometry
// residuals live).
Vec3 rotationLog(const Mat3& r) {
  Eigen::Quaterniond q(r);
  q.normalize();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const Vec3 v = q.vec();
  const double n = v.norm();
  if (n < 1e-12) return 2.0 * v / q.w();
  return v * (2.0 * std::atan2(n, q.w()) / n);
}

}  // namespace

void cameraInTraverse(const TraverseFromSite& pose, const SiteCamera& camera, Vec3& centre_m,
                      Mat3& camera_from_traverse) {
  centre_m = pose.position_m;
  centre_m.noalias() += pose.rotation * camera.centre_in_site_m;
  camera_from_traverse.noalias() = camera.m_site * pose.rotation.transpose();
}

void applySiteUpdate(const Vec6& update, TraverseFromSite& pose) {
  pose.position_m += update.head<3>();
  const Mat3 r = rotationFromVector(update.tail<3>());
  const Mat3 old = pose.rotation;
  pose.rotation.noalias() = r * old;
  const Eigen::Quaterniond q(pose.rotation);
  pose.rotation = q.normalized().toRotationMatrix();
}

void relativePose(const TraverseFromSite& a, const TraverseFromSite& b, Vec3& delta_position_m,
                  Mat3& delta_rotation) {
  const Vec3 v = b.position_m - a.position_m;
  delta_position_m.noalias() = a.rotation.transpose() * v;
  delta_rotation.noalias() = a.rotation.transpose() * b.rotation;
}

Mat3 rightJacobianInverse(const Vec3& phi) {
  const double theta = phi.norm();
  const Mat3 k = skew(phi);
  // (1/theta^2 - (1 + cos) / (2 theta sin)) -> 1/12 + theta^2/720 for small angles.
  const double c = theta < 1e-4
                       ? 1.0 / 12.0 + theta * theta / 720.0
                       : 1.0 / (theta * theta) - (1.0 + std::cos(theta)) / (2.0 * theta * std::sin(theta));
  Mat3 j = Mat3::Identity();
  j.noalias() += 0.5 * k;
  j.noalias() += c * (k * k);
  return j;
}

Status crossSiteObservationRow(const TraverseFromSite& pose, const SiteCamera& camera, const Vec3& point_m,
                               const Vec2& ideal_px, double sigma_px, Vec2& error, Mat2x6* d_pose,
                               Mat2x3* d_point) {
  Vec3 centre;
  Mat3 camera_from_traverse;
  cameraInTraverse(pose, camera, centre, camera_from_traverse);
  Vec2 pixel;
  Mat2x3 d_rotation, d_xyz;
  const bool derivatives = d_pose != nullptr || d_point != nullptr;
  const Status s = collinearity(camera.io, centre, camera_from_traverse, point_m, pixel, nullptr,
                                derivatives ? &d_rotation : nullptr, derivatives ? &d_xyz : nullptr);
  if (!ok(s)) return s;
  const double w = 1.0 / sigma_px;
  error = (pixel - ideal_px) * w;
  if (d_pose != nullptr) {
    // Camera update dC = dp - [Q C_s]x dtheta, delta = -M dtheta; d pixel / dC = -d pixel / dX.
    Vec3 arm;
    arm.noalias() = pose.rotation * camera.centre_in_site_m;
    d_pose->block<2, 3>(0, 0) = d_xyz * (-w);
    Mat2x3 d_theta;
    d_theta.noalias() = d_xyz * skew(arm);
    d_theta.noalias() -= d_rotation * camera_from_traverse;
    d_pose->block<2, 3>(0, 3) = d_theta * w;
  }
  if (d_point != nullptr) *d_point = d_xyz * w;
  return Status::kOk;
}

void odometryRows(const TraverseFromSite& a, const TraverseFromSite& b, const LegMeasurement& leg,
                  Vec6& error, Mat6* d_a, Mat6* d_b) {
  Vec3 d;
  Mat3 q_ab;
  relativePose(a, b, d, q_ab);
  Mat3 e_rot;
  e_rot.noalias() = leg.delta_rotation.transpose() * q_ab;
  const Vec3 phi = rotationLog(e_rot);
  const Vec3 w_pos = leg.sigma_position_m.cwiseInverse();
  const Vec3 w_rot = leg.sigma_rotation_rad.cwiseInverse();
  error.head<3>() = (d - leg.delta_position_m).cwiseProduct(w_pos);
  error.tail<3>() = phi.cwiseProduct(w_rot);
  if (d_a == nullptr && d_b == nullptr) return;
  const Mat3 qa_t = a.rotation.transpose();
  Mat3 rot_b;  // d phi / d dtheta_b = Jr^-1(phi) Q_b^T; d phi / d dtheta_a is its negative
  rot_b.noalias() = rightJacobianInverse(phi) * b.rotation.transpose();
  if (d_a != nullptr) {
    d_a->setZero();
    d_a->block<3, 3>(0, 0) = -qa_t;
    d_a->block<3, 3>(0, 3).noalias() = qa_t * skew(b.position_m - a.position_m);
    d_a->block<3, 3>(3, 3) = -rot_b;
    d_a->topRows<3>() = w_pos.asDiagonal() * d_a->topRows<3>();
    d_a->bottomRows<3>() = w_rot.asDiagonal() * d_a->bottomRows<3>();
  }
  if (d_b != nullptr) {
    d_b->setZero();
    d_b->block<3, 3>(0, 0) = qa_t;
    d_b->block<3, 3>(3, 3) = rot_b;
    d_b->topRows<3>() = w_pos.asDiagonal() * d_b->topRows<3>();
    d_b->bottomRows<3>() = w_rot.asDiagonal() * d_b->bottomRows<3>();
  }
}

}  // namespace areomap
