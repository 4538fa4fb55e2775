#include "firmware_core/match/EpipolarSearch.hpp"

#include <cmath>
#include <cstring>

#include "firmware_core/match/VectorKernels.hpp"

namespace areomap {
namespace {

bool inside(const Vec2& p, int32_t w, int32_t h) {
  return p.x() >= 0.0 && p.y() >= 0.0 && p.x() <= w - 1.0 && p.y() <= h - 1.0;
}

}  // namespace

Status epipolarCurve(const CameraModel& from, const CameraModel& to, const Vec2& pixel, double min_range_m,
                     double max_range_m, int32_t to_width, int32_t to_height, EpipolarCurve& curve) {
  curve.count = 0;
  if (!(min_range_m > 0.0) || !(max_range_m > min_range_m)) return Status::kInvalidArgument;
  Vec3 origin, direction;
  const Status s = unproject(from, pixel, origin, direction);
  if (!ok(s)) return s;
  // Length of the curve in `to`, from the projections of the two ends (a point behind `to` is skipped by
  // pulling the near end out until it projects, in at most 8 halvings of inverse range).
  const double inv_far = 1.0 / max_range_m;
  double inv_near = 1.0 / min_range_m;
  Vec2 p_far, p_near;
  if (!ok(project(to, origin + direction / inv_far, p_far))) return Status::kBehindCamera;
  bool near_ok = false;
  for (int32_t i = 0; i < 8 && !near_ok; ++i) {
    near_ok = ok(project(to, origin + direction / inv_near, p_near));
    if (!near_ok) inv_near = 0.5 * (inv_near + inv_far);
  }
  if (!near_ok) return Status::kBehindCamera;
  curve.far_px = p_far;
  const double length_px = (p_near - p_far).norm();
  int32_t steps = static_cast<int32_t>(std::ceil(length_px)) + 1;
  if (steps < 2) steps = 2;
  if (steps > kMaxEpipolarSteps) steps = kMaxEpipolarSteps;
  for (int32_t k = 0; k < steps; ++k) {
    const double inv = inv_far + (inv_near - inv_far) * static_cast<double>(k) / (steps - 1);
    Vec2 p;
    if (!ok(project(to, origin + direction / inv, p))) continue;
    if (!inside(p, to_width, to_height)) continue;
    curve.x[curve.count] = static_cast<float>(p.x());
    curve.y[curve.count] = static_cast<float>(p.y());
    ++curve.count;
  }
  return curve.count > 0 ? Status::kOk : Status::kBehindCamera;
}

namespace {

// lround of a curve coordinate (half away from zero), without the library call: exact for every float of
// magnitude below 2^31 (a float plus 0.5 is exact in double).
inline int32_t roundCurveCoordinate(float v) {
  const double d = v;
  return d >= 0.0 ? static_cast<int32_t>(d + 0.5) : -static_cast<int32_t>(0.5 - d);
}

// Calls visit(cx, cy, horizontal) for every searched centre of the curve in the search order (each rounded
// pixel once) with the direction of the band across it there (the local normal rounded to the dominant
// axis; the curve is close to a line): horizontal, the band runs along y.
template <typename Visit>
void forEachCurveCentre(const EpipolarCurve& curve, Visit&& visit) {
  int32_t last_x = -1000000, last_y = -1000000;
  for (int32_t k = 0; k < curve.count; ++k) {
    const int32_t cx = roundCurveCoordinate(curve.x[k]);
    const int32_t cy = roundCurveCoordinate(curve.y[k]);
    if (cx == last_x && cy == last_y) continue;
    last_x = cx;
    last_y = cy;
    const int32_t k0 = k > 0 ? k - 1 : k;
    const int32_t k1 = k + 1 < curve.count ? k + 1 : k;
    const double dx = curve.x[k1] - curve.x[k0];
    const double dy = curve.y[k1] - curve.y[k0];
    visit(cx, cy, std::fabs(dx) >= std::fabs(dy));
  }
}

// Calls visit(x, y) for every searched position, in the search order: the centres, +-band across the curve.
template <typename Visit>
void forEachCurvePosition(const EpipolarCurve& curve, int32_t band_px, Visit&& visit) {
  forEachCurveCentre(curve, [&](int32_t cx, int32_t cy, bool horizontal) {
    for (int32_t o = -band_px; o <= band_px; ++o) visit(horizontal ? cx : cx + o, horizontal ? cy + o : cy);
  });
}

// Floats in vector registers (GCC/Clang vector extension): four at the baseline (SSE, NEON, AltiVec; plain
// code elsewhere), eight in the AVX2 build of the kernel (VectorKernels.hpp). Loaded by memcpy (unaligned)
// and never passed or returned by value (no vector ABI on a 750 PowerPC).
typedef float CurveFloat4 __attribute__((vector_size(16)));
typedef double CurveDouble2 __attribute__((vector_size(16)));
#if AREOMAP_MATCH_AVX2_KERNELS
typedef float CurveFloat8 __attribute__((vector_size(32)));
typedef double CurveDouble4 __attribute__((vector_size(32)));
#endif

// Square roots of the lanes in place (IEEE, correctly rounded: every variant gives std::sqrt's value).
inline void sqrtLanes(CurveDouble2& v) {
#if defined(__x86_64__) && defined(__GNUC__)
  v = __builtin_ia32_sqrtpd(v);  // SSE2, in every x86-64
#else
  double lanes[2];
  std::memcpy(lanes, &v, sizeof lanes);
  for (double& l : lanes) l = std::sqrt(l);
  std::memcpy(&v, lanes, sizeof lanes);
#endif
}
#if AREOMAP_MATCH_AVX2_KERNELS
inline void sqrtLanes(CurveDouble4& v) {
  CurveDouble2 halves[2];
  std::memcpy(halves, &v, sizeof halves);
  sqrtLanes(halves[0]);
  sqrtLanes(halves[1]);
  std::memcpy(&v, halves, sizeof halves);
}
#endif

// Doubles as wide as V (four floats: two doubles).
template <typename V>
struct CurveDoubles;
template <>
struct CurveDoubles<CurveFloat4> {
  typedef CurveDouble2 Type;
};
#if AREOMAP_MATCH_AVX2_KERNELS
template <>
struct CurveDoubles<CurveFloat8> {
  typedef CurveDouble4 Type;
};
#endif

// Scores of the positions x = lo..hi of line y (windows inside the image) into out[0..hi-lo]: nccAt's value.
// tb: the template, each pixel in every lane of V.
template <typename V>
__attribute__((always_inline)) inline void scoreCurveLine(const NccTemplate& t, double var_t, const V* tb,
                                                          const ImageView& image, int32_t y, int32_t lo, int32_t hi,
                                                          CurveSearchScratch& s, double* out) {
  constexpr int32_t kChunk = CurveSearchScratch::kChunk;
  constexpr int32_t kLanes = static_cast<int32_t>(sizeof(V) / sizeof(float));
  constexpr int32_t kVectors = kChunk / kLanes;
  static_assert(kVectors * kLanes == kChunk, "a chunk is a whole number of vectors");
  const int32_t n = hi - lo + 1;
  const int32_t padded = ((n + kChunk - 1) / kChunk) * kChunk;
  const int32_t span = n + kNccSide - 1;  // image columns lo - r .. hi + r
  for (int32_t i = 0; i < span; ++i) {
    s.column_sum[i] = 0;
    s.column_sum_sq[i] = 0;
  }
  for (int32_t r = 0; r < kNccSide; ++r) {
    const uint8_t* src = image.row(y - kNccRadius + r) + (lo - kNccRadius);
    float* line = s.lines[r];
    for (int32_t i = 0; i < span; ++i) {
      const int32_t v = src[i];
      line[i] = static_cast<float>(v);
      s.column_sum[i] += v;
      s.column_sum_sq[i] += v * v;
    }
    for (int32_t i = span; i < padded + kNccSide - 1; ++i) line[i] = 0.0f;
  }
  int32_t ws = 0, ws2 = 0;  // window sums by a running sum of the column sums
  for (int32_t i = 0; i < kNccSide - 1; ++i) {
    ws += s.column_sum[i];
    ws2 += s.column_sum_sq[i];
  }
  for (int32_t i0 = 0; i0 < n; i0 += kChunk) {
    // The cross products of kChunk neighbouring positions (integer products summed in float: exact, every
    // partial sum is an integer below 2^24, whatever the vector width).
    // Even and odd template lines in separate sums: two independent chains of additions per vector.
    V acc_v[2][kVectors] = {};
    for (int32_t r = 0; r < kNccSide; ++r) {
      const float* line = s.lines[r] + i0;
      const V* tr = tb + r * kNccSide;
      V* acc_r = acc_v[r & 1];
      for (int32_t u = 0; u < kNccSide; ++u) {
        const V tv = tr[u];
        for (int32_t j = 0; j < kVectors; ++j) {
          V v;
          std::memcpy(&v, line + u + j * kLanes, sizeof v);
          acc_r[j] += tv * v;
        }
      }
    }
    float acc[kChunk];
    for (int32_t j = 0; j < kVectors; ++j) {
      const V total = acc_v[0][j] + acc_v[1][j];
      std::memcpy(acc + j * kLanes, &total, sizeof total);
    }
    // The window sums of the chunk's positions, then nccFromSums' operations on all of them at once.
    double sum[kChunk], sum_sq[kChunk], cross[kChunk], score[kChunk];
    const int32_t end = i0 + kChunk < n ? i0 + kChunk : n;
    for (int32_t i = i0; i < i0 + kChunk; ++i) {
      const bool here = i < end;
      ws += here ? s.column_sum[i + kNccSide - 1] : 0;
      ws2 += here ? s.column_sum_sq[i + kNccSide - 1] : 0;
      sum[i - i0] = ws;
      sum_sq[i - i0] = ws2;
      cross[i - i0] = acc[i - i0];
      ws -= here ? s.column_sum[i] : 0;
      ws2 -= here ? s.column_sum_sq[i] : 0;
    }
    typedef typename CurveDoubles<V>::Type D;
    constexpr int32_t kDoubleLanes = static_cast<int32_t>(sizeof(D) / sizeof(double));
    const D n_v = D{} + static_cast<double>(kNccPixels), t_sum = D{} + static_cast<double>(t.sum);
    const D var_t_v = D{} + var_t;
    for (int32_t j = 0; j < kChunk; j += kDoubleLanes) {
      D sum_v, sum_sq_v, cross_v;
      std::memcpy(&sum_v, sum + j, sizeof sum_v);
      std::memcpy(&sum_sq_v, sum_sq + j, sizeof sum_sq_v);
      std::memcpy(&cross_v, cross + j, sizeof cross_v);
      const D var_s = n_v * sum_sq_v - sum_v * sum_v;
      D root = var_s * var_t_v;
      sqrtLanes(root);
      const D ncc = (n_v * cross_v - sum_v * t_sum) / root;
      std::memcpy(score + j, &ncc, sizeof ncc);
      std::memcpy(sum_sq + j, &var_s, sizeof var_s);  // var_s, for the flat-window test below
    }
    for (int32_t i = i0; i < end; ++i) out[i] = sum_sq[i - i0] < kMinNccWindowVar ? kNccInvalid : score[i - i0];
  }
}

// Step 2 of searchAlongCurve: the scores of every line's interval (scratch.line_lo/hi/offset).
template <typename V>
__attribute__((always_inline)) inline void scoreCurveLines(const NccTemplate& t, const ImageView& image, int32_t y_lo,
                                                           int32_t y_hi, CurveSearchScratch& s) {
  V tb[kNccPixels];
  for (int32_t i = 0; i < kNccPixels; ++i) tb[i] = V{} + static_cast<float>(t.pixels[i]);
  const double var_t = nccTemplateVariance(t);
  for (int32_t y = y_lo; y <= y_hi; ++y) {
    if (s.line_hi[y] < s.line_lo[y]) continue;
    scoreCurveLine(t, var_t, tb, image, y, s.line_lo[y], s.line_hi[y], s, s.score + s.line_offset[y]);
  }
}

void scoreCurveLinesBaseline(const NccTemplate& t, const ImageView& image, int32_t y_lo, int32_t y_hi,
                             CurveSearchScratch& s) {
  scoreCurveLines<CurveFloat4>(t, image, y_lo, y_hi, s);
}

#if AREOMAP_MATCH_AVX2_KERNELS
__attribute__((target("avx2"))) void scoreCurveLinesAvx2(const NccTemplate& t, const ImageView& image, int32_t y_lo,
                                                          int32_t y_hi, CurveSearchScratch& s) {
  scoreCurveLines<CurveFloat8>(t, image, y_lo, y_hi, s);
}
#endif

using CurveLinesKernel = void (*)(const NccTemplate&, const ImageView&, int32_t, int32_t, CurveSearchScratch&);

CurveLinesKernel curveLinesKernel() {
#if AREOMAP_MATCH_AVX2_KERNELS
  if (matchUsesAvx2()) return scoreCurveLinesAvx2;
#endif
  return scoreCurveLinesBaseline;
}

}  // namespace

SearchHit searchAlongCurveDirect(const NccTemplate& t, const ImageView& target, const EpipolarCurve& curve,
                                 int32_t band_px) {
  SearchHit hit;
  if (band_px < 0) band_px = 0;
  if (band_px > kMaxEpipolarBandPx) band_px = kMaxEpipolarBandPx;
  forEachCurvePosition(curve, band_px, [&](int32_t x, int32_t y) { considerScore(hit, nccAt(t, target, x, y), x, y); });
  return hit;
}

SearchHit searchAlongCurve(const NccTemplate& t, const ImageView& target, const EpipolarCurve& curve,
                           int32_t band_px, CurveSearchScratch& scratch) {
  SearchHit hit;
  if (band_px < 0) band_px = 0;
  if (band_px > kMaxEpipolarBandPx) band_px = kMaxEpipolarBandPx;
  if (!t.textured || curve.count <= 0) return hit;
  const int32_t w = target.width;
  const int32_t h = target.height;
  auto inside_window = [&](int32_t x, int32_t y) {
    return x - kNccRadius >= 0 && y - kNccRadius >= 0 && x + kNccRadius < w && y + kNccRadius < h;
  };
  // 1. The centres, and the x interval of the searched positions on every line.
  int32_t centres = 0;
  int32_t c_lo = h, c_hi = -1;
  forEachCurveCentre(curve, [&](int32_t cx, int32_t cy, bool horizontal) {
    scratch.centre_x[centres] = cx;
    scratch.centre_y[centres] = cy;
    scratch.horizontal[centres++] = horizontal;
    c_lo = cy < c_lo ? cy : c_lo;
    c_hi = cy > c_hi ? cy : c_hi;
  });
  const int32_t first_line = c_lo - band_px > 0 ? c_lo - band_px : 0;
  const int32_t last_line = c_hi + band_px < h - 1 ? c_hi + band_px : h - 1;
  for (int32_t y = first_line; y <= last_line; ++y) {
    scratch.line_lo[y] = w;
    scratch.line_hi[y] = -1;
  }
  // Calls visit(x, y) for every searched position whose window is inside the image, in the search order.
  auto for_each_position = [&](auto&& visit) {
    for (int32_t c = 0; c < centres; ++c) {
      const int32_t cx = scratch.centre_x[c], cy = scratch.centre_y[c];
      const bool horizontal = scratch.horizontal[c];
      for (int32_t o = -band_px; o <= band_px; ++o) {
        const int32_t x = horizontal ? cx : cx + o, y = horizontal ? cy + o : cy;
        if (inside_window(x, y)) visit(x, y);
      }
    }
  };
  int32_t y_lo = h, y_hi = -1;
  for_each_position([&](int32_t x, int32_t y) {
    if (x < scratch.line_lo[y]) scratch.line_lo[y] = x;
    if (x > scratch.line_hi[y]) scratch.line_hi[y] = x;
    if (y < y_lo) y_lo = y;
    if (y > y_hi) y_hi = y;
  });
  int32_t total = 0;
  for (int32_t y = y_lo; y <= y_hi; ++y) {
    scratch.line_offset[y] = total;
    if (scratch.line_hi[y] >= scratch.line_lo[y]) total += scratch.line_hi[y] - scratch.line_lo[y] + 1;
  }
  if (total > CurveSearchScratch::kMaxScores) return searchAlongCurveDirect(t, target, curve, band_px);
  // 2. Scores line by line.
  curveLinesKernel()(t, target, y_lo, y_hi, scratch);
  // 3. The best and second peak in the search order.
  for_each_position([&](int32_t x, int32_t y) {
    considerScore(hit, scratch.score[scratch.line_offset[y] + x - scratch.line_lo[y]], x, y);
  });
  return hit;
}

}  // namespace areomap
