// A camera model in a resampled pixel frame, and binning: a frame larger than the rover's capacity
// (kMaxImageWidth x kMaxImageHeight) reduced by an integer factor b (b x b box mean) with its model
// rescaled exactly. Used by the rover node (frames above its capacity) and by the ground's tie matching
// (ground/ties/FullResolutionTies.hpp), so both bin the same way.
//
// Binned pixel frame: binned pixel (x_b, y_b) covers full-resolution pixels b x_b .. b x_b + b - 1, so its
// centre is the full-resolution point x = b x_b + (b - 1) / 2, i.e. x_b = (x + 0.5) / b - 0.5 (pixel
// centres at integers, README "Conventions"); likewise y. The last W mod b columns and H mod b lines, which
// no whole bin covers, are left out: the binned frame is floor(W / b) x floor(H / b).
//
// Why the rescaling is exact: every CAHV-family model projects x = (P - C).H / (P - C).A (CAHVOR and
// CAHVORE first move P along the ray in object space, with O, R, E and C only), so with o = (b - 1) / 2
// H' = (H - o A) / b gives (P - C).H' / (P - C).A = (x - o) / b exactly, and V' = (V - o A) / b likewise;
// C, A, O, R, E and the linearity are unchanged. The CAHV centres and scales follow (|A| = 1):
// hc' = A.H' = (hc - o) / b, vc' = (vc - o) / b, hs' = |A x H'| = hs / b, vs' = vs / b.
#pragma once

#include <cstdint>

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/camera/CameraModel.hpp"

namespace areomap {

// The same camera in a resampled pixel frame: pixel' = (pixel - offset_px) / scale, size width x height.
// Exact for CAHV, CAHVOR and CAHVORE (H' = (H - offset_x A) / scale, V' = (V - offset_y A) / scale; C, A,
// O, R, E unchanged).
CameraModel rescaledModel(const CameraModel& model, double scale, const Vec2& offset_px, int32_t width,
                          int32_t height);

// The smallest integer b >= 1 with floor(width / b) <= kMaxImageWidth and floor(height / b) <=
// kMaxImageHeight (1 for a frame within capacity). Closed form, no loop. width, height >= 0.
int32_t binningFactor(int32_t width, int32_t height);

// The model of the frame binned by b (b >= 1; the model itself for b = 1): rescaledModel with scale b and
// offset (b - 1) / 2 in x and y, size floor(width / b) x floor(height / b).
CameraModel binnedModel(const CameraModel& model, int32_t b);

// The inverse: the model of the full-resolution frame (width x height) of a model binned by b. Any rigid
// move of the binned model (movedModel) moves the full-resolution one alike, so an adjusted binned model
// maps back to the adjusted full-resolution model.
CameraModel unbinnedModel(const CameraModel& binned, int32_t b, int32_t width, int32_t height);

// The full-resolution position of a binned pixel coordinate: b x_b + (b - 1) / 2.
inline double fullResolutionPx(double binned_px, int32_t b) {
  return b * binned_px + 0.5 * (b - 1);
}

}  // namespace areomap
