// Normalised cross-correlation of an 11 x 11 template (kNccSide) against an 8-bit image, with exact
// integer sums, and the sub-pixel peak of a correlation surface (parabola in x and in y).
#pragma once

#include <cmath>
#include <cstdint>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/ImageView.hpp"

namespace areomap {

// Minimum template variance (grey^2 per pixel) for a patch to be correlated at all: a flat patch has no
// defined NCC.
constexpr double kMinNccVariance = 4.0;
// Returned for a window that leaves the image or is flat.
constexpr double kNccInvalid = -2.0;

struct NccTemplate {
  uint8_t pixels[kNccPixels] = {};
  int64_t sum = 0;
  int64_t sum_sq = 0;
  bool textured = false;  // variance >= kMinNccVariance
};

// n * sum_sq - sum^2 of the template (n = kNccPixels): the denominator's template part.
inline double nccTemplateVariance(const NccTemplate& t) {
  const double n = kNccPixels;
  return n * static_cast<double>(t.sum_sq) - static_cast<double>(t.sum) * static_cast<double>(t.sum);
}

// The NCC of n sample pairs from their sums: the template's sum t_sum and var_t = n * sum_sq - sum^2, the
// window's sum and sum of squares, and the sum of products; kNccInvalid when the window's
// n * sum_sq - sum^2 is below min_var_s (flat). The one formula of every NCC (nccAt, nccWarpedAt, the
// line-wise curve search, nccOfSamples), so that they agree bit for bit; the curve search repeats its
// operations in the same order on vectors of positions (EpipolarSearch.cpp, tested against nccAt).
inline double nccFromSums(double n, double t_sum, double var_t, double sum, double sum_sq, double cross,
                          double min_var_s) {
  const double var_s = n * sum_sq - sum * sum;
  if (var_s < min_var_s) return kNccInvalid;
  return (n * cross - sum * t_sum) / std::sqrt(var_s * var_t);
}

// The flat-window floor of the 11 x 11 template's NCC in nccFromSums' terms (n * sum_sq - sum^2).
constexpr double kMinNccWindowVar = kMinNccVariance * kNccPixels * kNccPixels;

// The NCC of a window of the 11 x 11 template from its sums (pixels, squares, products with the template)
// and the template's nccTemplateVariance; kNccInvalid when the window's variance is below kMinNccVariance.
inline double nccFromSums(const NccTemplate& t, double var_t, double sum, double sum_sq, double cross) {
  const double n = kNccPixels;
  return nccFromSums(n, static_cast<double>(t.sum), var_t, sum, sum_sq, cross, kMinNccWindowVar);
}

// The template centred on pixel (cx, cy); false when the window leaves the image.
bool extractTemplate(const ImageView& image, int32_t cx, int32_t cy, NccTemplate& t);
// Fills a template from stored pixels (a patch kept from an earlier pair).
void templateFromPixels(const uint8_t* pixels, NccTemplate& t);
// The template centred on a sub-pixel position (bilinear, rounded to 8 bits); false when it leaves the image.
bool extractTemplateAt(const ImageView& image, double cx, double cy, NccTemplate& t);

// NCC of the template with the window of `image` centred on (cx, cy); kNccInvalid when the window leaves
// the image or is flat.
double nccAt(const NccTemplate& t, const ImageView& image, int32_t cx, int32_t cy);

// The sample grid of the template warped by a local affine map `a` of template offsets about an integer
// centre: template pixel (u, v) (k = (v + r) * kNccSide + (u + r)) is compared with the image at
// centre + a * (u, v), that is at the integer offset (dx[k], dy[k]) from the centre plus the fraction
// (fx[k], fy[k]) in [0, 1], interpolated bilinearly with the weights below. The offsets and weights do not
// depend on the centre, so that a search over many centres shares them and every centre sees the same
// samples (WarpedSearch.hpp).
struct WarpedSamples {
  int32_t dx[kNccPixels];
  int32_t dy[kNccPixels];
  double fx[kNccPixels];
  double fy[kNccPixels];
  double gx[kNccPixels];  // 1 - fx
  double gy[kNccPixels];  // 1 - fy
  // The window's reach from its centre (r * (|a00| + |a01|), likewise in y) and the extreme integer offsets.
  double reach_x = 0.0;
  double reach_y = 0.0;
  int32_t min_dx = 0, max_dx = 0, min_dy = 0, max_dy = 0;
};
void warpSamples(const Mat2& a, WarpedSamples& s);
// Whether the warped window about (cx, cy) lies inside the image with the bilinear neighbour (x + 1, y + 1)
// of every sample.
bool warpedWindowInside(const WarpedSamples& s, const ImageView& image, int32_t cx, int32_t cy);

// NCC of the template with `image` resampled (bilinear) through the local affine map `a` of template
// offsets: template pixel (u, v) is compared with image((cx, cy) + a * (u, v)) (the samples of
// WarpedSamples). This is how a patch from another view is compared when perspective changes its shape
// (rotation, scale, foreshortening). kNccInvalid when the window leaves the image or is flat.
double nccWarpedAt(const NccTemplate& t, const ImageView& image, int32_t cx, int32_t cy, const WarpedSamples& s);
double nccWarpedAt(const NccTemplate& t, const ImageView& image, int32_t cx, int32_t cy, const Mat2& a);

// NCC of n sample pairs given as values, template `t` against window `s`, whatever their source (the
// ground samples float pyramids through a DEM-warped grid of any size); kNccInvalid when either's
// n * sum_sq - sum^2 is at or below min_variance. No allocation.
double nccOfSamples(const double* t, const double* s, int32_t n, double min_variance);

// Sub-pixel offset of a peak from the scores left/centre/right (|offset| <= 0.5; 0 when not a peak).
double parabolaOffset(double minus, double centre, double plus);

// Sub-pixel peak around the integer maximum (bx, by): evaluates the 4 neighbours and fits parabolas.
void refinePeak(const NccTemplate& t, const ImageView& image, int32_t bx, int32_t by, double best,
                double& x_px, double& y_px);

}  // namespace areomap
