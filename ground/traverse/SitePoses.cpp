#include "ground/traverse/SitePoses.hpp"

#include <cmath>

namespace areomap::traverse {

const char* poseSourceName(PoseSource s) {
  switch (s) {
    case PoseSource::kFirstSite:
      return "first_site";
    case PoseSource::kOdometry:
      return "odometry";
    case PoseSource::kCrossSiteTies:
      return "cross_site_ties";
  }
  return "unknown";
}

SitePoseSolution odometryPoses(const Traverse& traverse) {
  SitePoseSolution out;
  Eigen::Matrix4d cov = Eigen::Matrix4d::Zero();
  double driven = 0.0;
  for (std::size_t k = 0; k < traverse.sites.size(); ++k) {
    const TraverseSite& site = traverse.sites[k];
    SitePoseEstimate e;
    e.id = site.id;
    e.pose = site.apriori;
    if (k == 0 || !site.odometry) {
      e.source = PoseSource::kFirstSite;
    } else {
      // x_k = x_{k-1} + Rz(h_{k-1}) delta, h_k = h_{k-1} + delta_h: F = d(x_k, h_k)/d(x_{k-1}, h_{k-1}),
      // G = d(x_k, h_k)/d(delta, delta_h).
      const OdometryLeg& leg = *site.odometry;
      const double h = out.sites.back().pose.heading_rad;
      const double c = std::cos(h), s = std::sin(h);
      Eigen::Matrix3d r;
      r << c, -s, 0, s, c, 0, 0, 0, 1;
      Eigen::Matrix3d dr;
      dr << -s, -c, 0, c, -s, 0, 0, 0, 0;
      Eigen::Matrix4d f = Eigen::Matrix4d::Identity();
      f.block<3, 1>(0, 3) = dr * leg.delta_m;
      Eigen::Matrix4d g = Eigen::Matrix4d::Zero();
      g.block<3, 3>(0, 0) = r;
      g(3, 3) = 1.0;
      Eigen::Matrix4d q = Eigen::Matrix4d::Zero();
      q.diagonal() << leg.sigma_m.cwiseAbs2(), leg.sigma_heading_rad * leg.sigma_heading_rad;
      cov = f * cov * f.transpose() + g * q * g.transpose();
      driven += leg.distance_m;
      e.source = PoseSource::kOdometry;
    }
    e.covariance = cov;
    e.distance_m = driven;
    out.sites.push_back(e);
  }
  if (traverse.sites.size() > 1)
    out.notes.push_back(
        "Site poses from the odometry alone (no cross-site tie fixed them): their sigmas are the "
        "odometry's, chained leg by leg.");
  return out;
}

PositionErrors positionErrors(const std::vector<SitePose>& poses, const std::vector<double>& distance_m,
                              const TraverseTruth& truth, const std::vector<bool>& include) {
  PositionErrors e;
  double sum = 0.0, sum_pct = 0.0;
  int counted = 0, with_distance = 0;
  for (std::size_t k = 0; k < poses.size() && k < truth.poses.size(); ++k) {
    const double d = (poses[k].position_m - truth.poses[k].position_m).norm();
    e.per_site_m.push_back(d);
    if (k < include.size() && !include[k]) continue;
    sum += d * d;
    ++counted;
    if (k < distance_m.size() && distance_m[k] > 0.0) {
      const double pct = 100.0 * d / distance_m[k];
      sum_pct += pct * pct;
      ++with_distance;
    }
  }
  if (counted > 0) e.rms_m = std::sqrt(sum / counted);
  if (with_distance > 0) e.rms_pct = std::sqrt(sum_pct / with_distance);
  return e;
}

CameraModel toTraverseFrame(const CameraModel& model, const SitePose& pose) {
  const Eigen::Matrix3d r = pose.rotation();
  CameraModel m = model;
  m.c = pose.toTraverse(model.c);
  m.a = r * model.a;
  m.h = r * model.h;
  m.v = r * model.v;
  m.o = r * model.o;
  return m;
}

}  // namespace areomap::traverse
