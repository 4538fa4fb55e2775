#include "firmware_core/adjust/AdjustWorkspace.hpp"

namespace areomap {

void AdjustWorkspace::buildImageIndex(const Network& net) {
  const int32_t n_img = net.imageCount();
  for (int32_t i = 0; i <= n_img; ++i) image_obs_start[i] = 0;
  for (int32_t k = 0; k < net.observationCount(); ++k) ++image_obs_start[net.observation(k).image + 1];
  for (int32_t i = 0; i < n_img; ++i) image_obs_start[i + 1] += image_obs_start[i];
  // Fill using image_obs_start shifted by one as running cursors, then restore.
  for (int32_t k = 0; k < net.observationCount(); ++k) {
    const int32_t img = net.observation(k).image;
    image_obs[image_obs_start[img]++] = k;
  }
  for (int32_t i = n_img; i > 0; --i) image_obs_start[i] = image_obs_start[i - 1];
  image_obs_start[0] = 0;
}

}  // namespace areomap
