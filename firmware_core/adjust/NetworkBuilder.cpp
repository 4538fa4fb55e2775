#include "firmware_core/adjust/NetworkBuilder.hpp"

namespace areomap {

void NetworkBuilder::reset() {
  for (int32_t i = 0; i < kMaxImages; ++i) net_image_of_[i] = -1;
  for (int32_t i = 0; i < kMaxTiePoints; ++i) net_point_of_[i] = -1;
  synced_observations_ = 0;
  synced_points_ = 0;
}

int32_t NetworkBuilder::networkImage(int32_t tie_image) const {
  if (tie_image < 0 || tie_image >= kMaxImages) return -1;
  return net_image_of_[tie_image];
}

Status NetworkBuilder::syncPair(const TieList& ties, int32_t sol, int32_t tier, const CameraModel& left,
                                const CameraModel* right, Network& net, int32_t& failed_observations) {
  failed_observations = 0;
  const int32_t pair = ties.pair_count - 1;
  if (pair < 0 || pair >= kMaxPairs) return Status::kInvalidArgument;
  if (ties.point_count > kMaxTiePoints) return Status::kCapacityExceeded;
  PhotogrammetricCamera cams[2];
  ConversionResidual residual;
  Status s = cahvorToPhotogrammetric(left, cams[0], residual);
  if (!ok(s)) return s;
  if (right != nullptr) {
    s = cahvorToPhotogrammetric(*right, cams[1], residual);
    if (!ok(s)) return s;
  }
  int32_t net_pair = -1;
  s = net.addPair(sol, tier, cams[0].io, cams[0].eo.centre_m, cams[0].m,
                  right != nullptr ? &cams[1].io : nullptr, cams[1].eo.centre_m, cams[1].m, net_pair);
  if (!ok(s)) return s;
  const int32_t images[2] = {net.pair(net_pair).left, net.pair(net_pair).right};
  for (int32_t side = 0; side < 2; ++side) {
    if (images[side] < 0) continue;
    net_image_of_[2 * pair + side] = images[side];
    cameras_[images[side]] = cams[side];
    models_[images[side]] = side == 0 ? left : *right;
  }
  // New points, then every observation made since the last call.
  for (int32_t p = synced_points_; p < ties.point_count; ++p) {
    int32_t id = -1;
    if (ok(net.addPoint(ties.points[p].ground_m, id))) net_point_of_[p] = id;
  }
  synced_points_ = ties.point_count;
  for (int32_t i = synced_observations_; i < ties.observation_count; ++i) {
    const TieObservation& o = ties.observations[i];
    const int32_t image = networkImage(o.image);
    const int32_t point = o.point >= 0 && o.point < ties.point_count ? net_point_of_[o.point] : -1;
    Vec2 ideal;
    if (image < 0 || point < 0 ||
        !ok(pixelToIdeal(models_[image], cameras_[image], Vec2(o.sample_px, o.line_px), ideal)) ||
        !ok(net.addObservation(point, image, ideal, sigma_px))) {
      ++failed_observations;
    }
  }
  synced_observations_ = ties.observation_count;
  return Status::kOk;
}

}  // namespace areomap
