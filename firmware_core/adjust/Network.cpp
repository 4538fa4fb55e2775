#include "firmware_core/adjust/Network.hpp"

#include <cmath>

namespace areomap {

void Network::clear() {
  image_count_ = 0;
  pair_count_ = 0;
  point_count_ = 0;
  observation_count_ = 0;
}

Status Network::addPair(int32_t sol, int32_t tier, const InteriorOrientation& left_io,
                        const Vec3& left_centre_m, const Mat3& left_m, const InteriorOrientation* right_io,
                        const Vec3& right_centre_m, const Mat3& right_m, int32_t& pair_index) {
  if (sol < 0 || sol >= kMaxSols || tier < 0 || tier >= kMaxTiers || !(left_io.f_px > 0.0)) {
    return Status::kInvalidArgument;
  }
  if (right_io != nullptr && !(right_io->f_px > 0.0)) {
    return Status::kInvalidArgument;
  }
  const int32_t needed = right_io != nullptr ? 2 : 1;
  if (pair_count_ >= kMaxPairs || image_count_ + needed > kMaxImages) {
    return Status::kCapacityExceeded;
  }
  if (!left_centre_m.allFinite() || !left_m.allFinite() || !right_centre_m.allFinite() ||
      !right_m.allFinite()) {
    return Status::kNotFinite;
  }
  pair_index = pair_count_;
  NetPair& p = pairs_[pair_count_++];
  p.left = image_count_;
  p.right = -1;
  p.covariance.setZero();
  const InteriorOrientation* ios[2] = {&left_io, right_io};
  const Vec3* centres[2] = {&left_centre_m, &right_centre_m};
  const Mat3* ms[2] = {&left_m, &right_m};
  for (int32_t s = 0; s < needed; ++s) {
    NetImage& im = images_[image_count_];
    im = NetImage{};
    im.pair = pair_index;
    im.side = s == 0 ? Side::kLeft : Side::kRight;
    im.sol = sol;
    im.tier = tier;
    im.io = *ios[s];
    im.centre_m = *centres[s];
    im.m = *ms[s];
    im.centre_apriori_m = *centres[s];
    im.m_apriori = *ms[s];
    if (s == 1) p.right = image_count_;
    ++image_count_;
  }
  return Status::kOk;
}

Status Network::addPoint(const Vec3& xyz_m, int32_t& point_index) {
  if (point_count_ >= kMaxTiePoints) {
    return Status::kCapacityExceeded;
  }
  if (!xyz_m.allFinite()) {
    return Status::kNotFinite;
  }
  point_index = point_count_;
  NetPoint& p = points_[point_count_++];
  p = NetPoint{};
  p.xyz_m = xyz_m;
  return Status::kOk;
}

Status Network::addObservation(int32_t point, int32_t image, const Vec2& ideal_px, double sigma_px) {
  if (point < 0 || point >= point_count_ || image < 0 || image >= image_count_ || !(sigma_px > 0.0)) {
    return Status::kInvalidArgument;
  }
  if (!ideal_px.allFinite()) {
    return Status::kNotFinite;
  }
  NetPoint& p = points_[point];
  for (int32_t k = 0; k < p.obs_count; ++k) {
    if (observations_[p.obs[k]].image == image) {
      return Status::kInvalidArgument;
    }
  }
  if (p.obs_count >= kMaxObsPerPoint || observation_count_ >= kMaxObservations) {
    return Status::kCapacityExceeded;
  }
  NetObservation& o = observations_[observation_count_];
  o.point = point;
  o.image = image;
  o.ideal_px = ideal_px;
  o.sigma_px = sigma_px;
  o.rejected = false;
  p.obs[p.obs_count++] = observation_count_;
  ++observation_count_;
  return Status::kOk;
}

Vec3 rayOfIdealPixel(const InteriorOrientation& io, const Mat3& m, const Vec2& ideal_px) {
  // Inverse of collinearity(): sample = x0 - f dx/dz, line = y0 + f dy/dz, with dz = -1.
  const Vec3 d((ideal_px.x() - io.x0_px) / io.f_px, (io.y0_px - ideal_px.y()) / io.f_px, -1.0);
  Vec3 ray;
  ray.noalias() = m.transpose() * d;
  return ray.normalized();
}

Status Network::triangulate(int32_t point) {
  if (point < 0 || point >= point_count_) {
    return Status::kInvalidArgument;
  }
  NetPoint& p = points_[point];
  Vec3 origins[kMaxObsPerPoint];
  Vec3 dirs[kMaxObsPerPoint];
  int32_t n = 0;
  for (int32_t k = 0; k < p.obs_count; ++k) {
    const NetObservation& o = observations_[p.obs[k]];
    if (o.rejected) continue;
    const NetImage& im = images_[o.image];
    origins[n] = im.centre_m;
    dirs[n] = rayOfIdealPixel(im.io, im.m, o.ideal_px);
    ++n;
  }
  Vec3 xyz;
  const Status s = intersectRays(origins, dirs, n, xyz);
  p.solvable = ok(s);
  if (ok(s)) p.xyz_m = xyz;
  return s;
}

Status Network::triangulateAll(int32_t& failed_count) {
  failed_count = 0;
  for (int32_t i = 0; i < point_count_; ++i) {
    if (!ok(triangulate(i))) ++failed_count;
  }
  return failed_count == 0 ? Status::kOk : Status::kDegenerate;
}

void Network::resetToApriori() {
  for (int32_t i = 0; i < image_count_; ++i) {
    images_[i].centre_m = images_[i].centre_apriori_m;
    images_[i].m = images_[i].m_apriori;
    images_[i].sigma.setZero();
  }
  for (int32_t i = 0; i < pair_count_; ++i) pairs_[i].covariance.setZero();
  for (int32_t i = 0; i < observation_count_; ++i) observations_[i].rejected = false;
}

Vec3 rotationVector(const Mat3& r) {
  const Eigen::AngleAxisd aa(r);
  return aa.axis() * aa.angle();
}

double rotationAngle(const Mat3& a, const Mat3& b) {
  Mat3 d;
  d.noalias() = a * b.transpose();
  return rotationVector(d).norm();
}

}  // namespace areomap
