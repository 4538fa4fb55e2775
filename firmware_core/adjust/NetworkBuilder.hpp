// Puts a neutral tie list (firmware_core/match/TieList.hpp, as PanoramaMatcher makes it) into the adjustment
// Network, incrementally: after each new pair of the list, syncPair adds the pair's cameras (a-priori models
// converted to the photogrammetric form) and every point and observation the list has gained since the last
// call (intra ties of the new pair and inter ties that earlier points gained in it). Observations enter as
// ideal pixels through the exact camera inverse (pixelToIdeal). Zero heap; 0.16 MiB of fixed tables.
#pragma once

#include <cstdint>

#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/camera/CameraConversion.hpp"
#include "firmware_core/match/TieList.hpp"

namespace areomap {

class NetworkBuilder {
 public:
  void reset();

  // Call once per pair, right after the pair (ties.pair_count - 1) entered the tie list, with its models.
  // `failed_observations` counts observations that could not be mapped or added (kept out of the network).
  [[nodiscard]] Status syncPair(const TieList& ties, int32_t sol, int32_t tier, const CameraModel& left,
                                const CameraModel* right, Network& net, int32_t& failed_observations);

  // The network image of a tie-list image index (2 * pair + side); -1 when absent.
  int32_t networkImage(int32_t tie_image) const;
  // The photogrammetric camera of a network image (a-priori) and its model.
  const PhotogrammetricCamera& camera(int32_t net_image) const { return cameras_[net_image]; }
  const CameraModel& model(int32_t net_image) const { return models_[net_image]; }
  double sigma_px = 0.3;  // a-priori observation sigma given to the network

 private:
  PhotogrammetricCamera cameras_[kMaxImages];
  CameraModel models_[kMaxImages];
  int32_t net_image_of_[kMaxImages];
  int32_t net_point_of_[kMaxTiePoints];
  int32_t synced_observations_ = 0;
  int32_t synced_points_ = 0;
};

}  // namespace areomap
