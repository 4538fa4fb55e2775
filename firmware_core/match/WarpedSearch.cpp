#include "firmware_core/match/WarpedSearch.hpp"

#include <algorithm>
#include <cstring>

namespace areomap {
namespace {

// Two doubles in one vector register (SSE2, NEON; plain code elsewhere): GCC/Clang vector extension. Lanes
// are independent, so each lane's result is the scalar code's; loaded by memcpy (unaligned), scalars
// broadcast by initialisation, never passed or returned by value (no vector ABI on a 750 PowerPC).
typedef double WarpDouble2 __attribute__((vector_size(16)));

constexpr int32_t kWarpLanes = 4;  // centres per block: two vectors

// Scores of the four centres whose first window sample k lies at region[base + offset[k]] (the region holds
// the image as doubles, `stride` per line; every window inside it) into out[0..3]: nccWarpedAt's value.
void scoreFourWarped(const NccTemplate& t, double var_t, const WarpedSamples& s, const int32_t* offset,
                     const double* region, int32_t base, int32_t stride, double* out) {
  WarpDouble2 sum_a = {}, sum_sq_a = {}, cross_a = {};
  WarpDouble2 sum_b = {}, sum_sq_b = {}, cross_b = {};
  for (int32_t k = 0; k < kNccPixels; ++k) {
    const double* r0 = region + base + offset[k];
    const double* r1 = r0 + stride;
    WarpDouble2 v00a, v01a, v10a, v11a, v00b, v01b, v10b, v11b;
    std::memcpy(&v00a, r0, sizeof v00a);
    std::memcpy(&v01a, r0 + 1, sizeof v01a);
    std::memcpy(&v10a, r1, sizeof v10a);
    std::memcpy(&v11a, r1 + 1, sizeof v11a);
    std::memcpy(&v00b, r0 + 2, sizeof v00b);
    std::memcpy(&v01b, r0 + 3, sizeof v01b);
    std::memcpy(&v10b, r1 + 2, sizeof v10b);
    std::memcpy(&v11b, r1 + 3, sizeof v11b);
    const WarpDouble2 gx = {s.gx[k], s.gx[k]}, fx = {s.fx[k], s.fx[k]};
    const WarpDouble2 gy = {s.gy[k], s.gy[k]}, fy = {s.fy[k], s.fy[k]};
    const double tv = t.pixels[k];
    const WarpDouble2 tk = {tv, tv};
    const WarpDouble2 value_a = gy * (gx * v00a + fx * v01a) + fy * (gx * v10a + fx * v11a);
    const WarpDouble2 value_b = gy * (gx * v00b + fx * v01b) + fy * (gx * v10b + fx * v11b);
    sum_a += value_a;
    sum_sq_a += value_a * value_a;
    cross_a += value_a * tk;
    sum_b += value_b;
    sum_sq_b += value_b * value_b;
    cross_b += value_b * tk;
  }
  double a[kWarpLanes], b[kWarpLanes], c[kWarpLanes];
  std::memcpy(a, &sum_a, sizeof sum_a);
  std::memcpy(a + 2, &sum_b, sizeof sum_b);
  std::memcpy(b, &sum_sq_a, sizeof sum_sq_a);
  std::memcpy(b + 2, &sum_sq_b, sizeof sum_sq_b);
  std::memcpy(c, &cross_a, sizeof cross_a);
  std::memcpy(c + 2, &cross_b, sizeof cross_b);
  for (int32_t i = 0; i < kWarpLanes; ++i) out[i] = nccFromSums(t, var_t, a[i], b[i], c[i]);
}

}  // namespace

SearchHit searchWindowWarpedDirect(const NccTemplate& t, const ImageView& target, int32_t cx, int32_t cy,
                                   int32_t radius, const Mat2& a) {
  SearchHit hit;
  if (radius > kInterOffsetSearchRadiusPx) radius = kInterOffsetSearchRadiusPx;
  WarpedSamples s;
  warpSamples(a, s);
  for (int32_t dy = -radius; dy <= radius; ++dy) {
    for (int32_t dx = -radius; dx <= radius; ++dx) {
      considerScore(hit, nccWarpedAt(t, target, cx + dx, cy + dy, s), cx + dx, cy + dy);
    }
  }
  return hit;
}

SearchHit searchWindowWarped(const NccTemplate& t, const ImageView& target, int32_t cx, int32_t cy, int32_t radius,
                             const Mat2& a, WarpedSearchScratch& scratch) {
  SearchHit hit;
  if (radius > kInterOffsetSearchRadiusPx) radius = kInterOffsetSearchRadiusPx;
  if (radius < 0 || !t.textured) return hit;
  WarpedSamples& s = scratch.samples;
  warpSamples(a, s);
  // The image under every window of the search as doubles (clipped to the image: only windows inside it
  // are scored); a warp too wide for the scratch is searched by nccWarpedAt at every centre.
  const int32_t x0 = std::max(0, cx - radius + s.min_dx), x1 = std::min(target.width - 1, cx + radius + s.max_dx + 1);
  const int32_t y0 = std::max(0, cy - radius + s.min_dy), y1 = std::min(target.height - 1, cy + radius + s.max_dy + 1);
  if (x1 < x0 || y1 < y0) return hit;
  const int32_t stride = x1 - x0 + 1;
  if (stride > WarpedSearchScratch::kSide || y1 - y0 + 1 > WarpedSearchScratch::kSide) {
    return searchWindowWarpedDirect(t, target, cx, cy, radius, a);
  }
  for (int32_t y = y0; y <= y1; ++y) {
    const uint8_t* src = target.row(y) + x0;
    double* dst = scratch.region + (y - y0) * stride;
    for (int32_t x = 0; x < stride; ++x) dst[x] = src[x];
  }
  for (int32_t k = 0; k < kNccPixels; ++k) scratch.offset[k] = s.dy[k] * stride + s.dx[k];
  const double var_t = nccTemplateVariance(t);
  const int32_t side = 2 * radius + 1;
  double* score = scratch.score;
  for (int32_t dy = -radius; dy <= radius; ++dy) {
    const int32_t y = cy + dy;
    // The centres of this row whose window is inside form one interval (the test is monotone in x).
    int32_t lo = 0;
    while (lo < side && !warpedWindowInside(s, target, cx - radius + lo, y)) ++lo;
    int32_t hi = lo;
    while (hi < side && warpedWindowInside(s, target, cx - radius + hi, y)) ++hi;
    if (hi - lo < kWarpLanes) {
      for (int32_t i = lo; i < hi; ++i) score[i] = nccWarpedAt(t, target, cx - radius + i, y, s);
    } else {
      // Blocks of four; the last block ends at hi (overlapping the one before it: lanes are independent).
      for (int32_t i = lo; i < hi; i += kWarpLanes) {
        const int32_t start = i + kWarpLanes <= hi ? i : hi - kWarpLanes;
        const int32_t base = (y - y0) * stride + (cx - radius + start - x0);
        scoreFourWarped(t, var_t, s, scratch.offset, scratch.region, base, stride, score + start);
      }
    }
    for (int32_t i = lo; i < hi; ++i) considerScore(hit, score[i], cx - radius + i, y);
  }
  return hit;
}

void refinePeakWarped(const NccTemplate& t, const ImageView& image, int32_t bx, int32_t by, double best,
                      const Mat2& a, double& x_px, double& y_px) {
  WarpedSamples s;
  warpSamples(a, s);
  const double l = nccWarpedAt(t, image, bx - 1, by, s);
  const double r = nccWarpedAt(t, image, bx + 1, by, s);
  const double u = nccWarpedAt(t, image, bx, by - 1, s);
  const double d = nccWarpedAt(t, image, bx, by + 1, s);
  x_px = bx + parabolaOffset(l, best, r);
  y_px = by + parabolaOffset(u, best, d);
}

}  // namespace areomap
