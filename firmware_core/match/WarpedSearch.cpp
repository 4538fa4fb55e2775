#include "firmware_core/match/WarpedSearch.hpp"

#include <algorithm>
#include <cstring>

#include "firmware_core/match/VectorKernels.hpp"

namespace areomap {
namespace {

// Doubles in vector registers (GCC/Clang vector extension): two at the baseline (SSE2, NEON; plain code
// elsewhere), four in the AVX2 build of the kernel (VectorKernels.hpp). Loaded by memcpy (unaligned),
// scalars broadcast by adding them to a zero vector, never passed or returned by value (no vector ABI on a
// 750 PowerPC).
typedef double WarpDouble2 __attribute__((vector_size(16)));
#if AREOMAP_MATCH_AVX2_KERNELS
typedef double WarpDouble4 __attribute__((vector_size(32)));
#endif

constexpr int32_t kWarpLanes = 4;  // centres per block

// Scores of the four centres whose first window sample k lies at region[base + offset[k]] (the region holds
// the image as doubles, `stride` per line; every window inside it) into out[0..3]: nccWarpedAt's value.
template <typename V>
__attribute__((always_inline)) inline void scoreFourWarped(const NccTemplate& t, double var_t,
                                                           const WarpedSamples& s, const int32_t* offset,
                                                           const double* region, int32_t base, int32_t stride,
                                                           double* out) {
  constexpr int32_t kLanes = static_cast<int32_t>(sizeof(V) / sizeof(double));
  constexpr int32_t kVectors = kWarpLanes / kLanes;
  V sum[kVectors] = {}, sum_sq[kVectors] = {}, cross[kVectors] = {};
  for (int32_t k = 0; k < kNccPixels; ++k) {
    const double* r0 = region + base + offset[k];
    const double* r1 = r0 + stride;
    const V gx = V{} + s.gx[k], fx = V{} + s.fx[k], gy = V{} + s.gy[k], fy = V{} + s.fy[k];
    const V tk = V{} + static_cast<double>(t.pixels[k]);
    for (int32_t j = 0; j < kVectors; ++j) {
      V v00, v01, v10, v11;
      std::memcpy(&v00, r0 + j * kLanes, sizeof v00);
      std::memcpy(&v01, r0 + j * kLanes + 1, sizeof v01);
      std::memcpy(&v10, r1 + j * kLanes, sizeof v10);
      std::memcpy(&v11, r1 + j * kLanes + 1, sizeof v11);
      const V value = gy * (gx * v00 + fx * v01) + fy * (gx * v10 + fx * v11);
      sum[j] += value;
      sum_sq[j] += value * value;
      cross[j] += value * tk;
    }
  }
  double a[kWarpLanes], b[kWarpLanes], c[kWarpLanes];
  for (int32_t j = 0; j < kVectors; ++j) {
    std::memcpy(a + j * kLanes, &sum[j], sizeof sum[j]);
    std::memcpy(b + j * kLanes, &sum_sq[j], sizeof sum_sq[j]);
    std::memcpy(c + j * kLanes, &cross[j], sizeof cross[j]);
  }
  for (int32_t i = 0; i < kWarpLanes; ++i) out[i] = nccFromSums(t, var_t, a[i], b[i], c[i]);
}

// The scores of the centres cx0 + [lo, hi) of line y (hi - lo >= kWarpLanes, windows inside the region)
// into score[lo, hi): blocks of four, the last one ending at hi (overlapping the one before it: lanes are
// independent).
template <typename V>
__attribute__((always_inline)) inline void scoreWarpedRow(const NccTemplate& t, double var_t,
                                                          const WarpedSamples& s, const int32_t* offset,
                                                          const double* region, int32_t row_base,
                                                          int32_t stride, int32_t lo, int32_t hi,
                                                          double* score) {
  for (int32_t i = lo; i < hi; i += kWarpLanes) {
    const int32_t start = i + kWarpLanes <= hi ? i : hi - kWarpLanes;
    scoreFourWarped<V>(t, var_t, s, offset, region, row_base + start, stride, score + start);
  }
}

void scoreWarpedRowBaseline(const NccTemplate& t, double var_t, const WarpedSamples& s, const int32_t* offset,
                            const double* region, int32_t row_base, int32_t stride, int32_t lo, int32_t hi,
                            double* score) {
  scoreWarpedRow<WarpDouble2>(t, var_t, s, offset, region, row_base, stride, lo, hi, score);
}

#if AREOMAP_MATCH_AVX2_KERNELS
__attribute__((target("avx2"))) void scoreWarpedRowAvx2(const NccTemplate& t, double var_t,
                                                        const WarpedSamples& s, const int32_t* offset,
                                                        const double* region, int32_t row_base,
                                                        int32_t stride, int32_t lo, int32_t hi,
                                                        double* score) {
  scoreWarpedRow<WarpDouble4>(t, var_t, s, offset, region, row_base, stride, lo, hi, score);
}
#endif

using WarpedRowKernel = void (*)(const NccTemplate&, double, const WarpedSamples&, const int32_t*,
                                 const double*, int32_t, int32_t, int32_t, int32_t, double*);

WarpedRowKernel warpedRowKernel() {
#if AREOMAP_MATCH_AVX2_KERNELS
  if (matchUsesAvx2()) return scoreWarpedRowAvx2;
#endif
  return scoreWarpedRowBaseline;
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

SearchHit searchWindowWarped(const NccTemplate& t, const ImageView& target, int32_t cx, int32_t cy,
                             int32_t radius, const Mat2& a, WarpedSearchScratch& scratch) {
  SearchHit hit;
  if (radius > kInterOffsetSearchRadiusPx) radius = kInterOffsetSearchRadiusPx;
  if (radius < 0 || !t.textured) return hit;
  WarpedSamples& s = scratch.samples;
  warpSamples(a, s);
  // The image under every window of the search as doubles (clipped to the image: only windows inside it
  // are scored); a warp too wide for the scratch is searched by nccWarpedAt at every centre.
  const int32_t x0 = std::max(0, cx - radius + s.min_dx),
                x1 = std::min(target.width - 1, cx + radius + s.max_dx + 1);
  const int32_t y0 = std::max(0, cy - radius + s.min_dy),
                y1 = std::min(target.height - 1, cy + radius + s.max_dy + 1);
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
  const WarpedRowKernel score_row = warpedRowKernel();
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
      score_row(t, var_t, s, scratch.offset, scratch.region, (y - y0) * stride + (cx - radius - x0), stride,
                lo, hi, score);
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
