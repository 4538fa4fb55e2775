// Förstner interest operator (paper §3.4; shared/reference/camera-models.md): central-difference gradients
// gx = (I(x+1,y) - I(x-1,y)) / 2, gy likewise, the structure tensor N summed over a (2r+1)^2 window,
// weight w = det N / tr N and roundness q = 4 det N / (tr N)^2. Points keep q > q_min and
// w > max(w_min, w_mean_factor * mean w), are local maxima of w in a (2n+1)^2 neighbourhood, get a sub-pixel
// location from a parabola through w in x and y, and are spread over the image by a grid (the best
// `max_per_cell` per cell). Fixed memory: the w and q maps live in a caller-owned workspace (8 MiB for a
// 1024^2 frame; make it static), window sums run over a ring of rows with exact integer arithmetic.
#pragma once

#include <cstdint>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/ImageView.hpp"
#include "firmware_core/base/Status.hpp"

namespace areomap {

// Smallest spreading-grid cell (a 256-px frame at 1/32 of its side): at most 2 points per 8 x 8 px.
constexpr int32_t kMinSpreadingCellPx = 8;

struct InterestPoint {
  float x_px = 0.0f;  // sub-pixel sample
  float y_px = 0.0f;  // sub-pixel line
  float weight = 0.0f;
  float roundness = 0.0f;
  int32_t pixel_x = 0;  // the integer w maximum (its spreading cell)
  int32_t pixel_y = 0;
};

struct ForstnerParams {
  int32_t window_radius = 2;     // structure-tensor window (2r+1)^2, r <= kMaxForstnerRadius
  double q_min = 0.5;            // roundness threshold
  double w_mean_factor = 1.0;    // w threshold as a multiple of the image's mean w
  double w_min = 20.0;           // absolute w floor (grey^2): below it an image has no usable texture
  int32_t nms_radius = 3;        // non-maximum suppression neighbourhood (2n+1)^2
  int32_t cell_px = 32;          // spreading grid cell
  int32_t max_per_cell = 2;      // <= kMaxInterestPointsPerCell
  int32_t min_points = 16;       // fewer points than this: Status::kNoTexture
  int32_t border_px = 0;         // extra border kept free of points (e.g. the NCC radius)
};

// Caller-owned maps (w and q per pixel, 0 where undefined) and the window-sum ring.
struct ForstnerWorkspace {
  float weight[kMaxImagePixels];
  float roundness[kMaxImagePixels];
  int32_t width = 0;
  int32_t height = 0;
  // Ring of per-row gradient products (gx^2, gx*gy, gy^2 in units of (2 g)^2) and their column sums.
  int32_t ring[3][2 * kMaxForstnerRadius + 1][kMaxImageWidth];
  int64_t column_sum[3][kMaxImageWidth];
  InterestPoint cell_best[(kMaxImageWidth / 16) * (kMaxImageHeight / 16)][kMaxInterestPointsPerCell];
  int32_t cell_count[(kMaxImageWidth / 16) * (kMaxImageHeight / 16)];
};

// Fills workspace.weight / roundness for every pixel (0 within r+1 of the border). kInvalidArgument for a
// bad view or radius, kCapacityExceeded for an image larger than kMaxImageWidth x kMaxImageHeight.
[[nodiscard]] Status computeForstnerMaps(const ImageView& image, const ForstnerParams& params,
                                         ForstnerWorkspace& workspace);

// Detects the interest points (computes the maps first). `count` receives the number written to `points`
// (at most `capacity`, best first within each cell, cells in raster order). kNoTexture when fewer than
// params.min_points survive (blank, saturated or featureless image); the points found are still returned.
[[nodiscard]] Status detectInterestPoints(const ImageView& image, const ForstnerParams& params,
                                          ForstnerWorkspace& workspace, InterestPoint* points,
                                          int32_t capacity, int32_t& count);

}  // namespace areomap
