#include "firmware_core/match/EpipolarSearch.hpp"

#include <cmath>
#include <cstring>

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

// Calls visit(x, y) for every searched position, in the search order: along the curve (each rounded pixel
// once), +-band across it (the local normal rounded to the dominant axis; the curve is close to a line).
template <typename Visit>
void forEachCurvePosition(const EpipolarCurve& curve, int32_t band_px, Visit&& visit) {
  int32_t last_x = -1000000, last_y = -1000000;
  for (int32_t k = 0; k < curve.count; ++k) {
    const int32_t cx = static_cast<int32_t>(std::lround(curve.x[k]));
    const int32_t cy = static_cast<int32_t>(std::lround(curve.y[k]));
    if (cx == last_x && cy == last_y) continue;
    last_x = cx;
    last_y = cy;
    const int32_t k0 = k > 0 ? k - 1 : k;
    const int32_t k1 = k + 1 < curve.count ? k + 1 : k;
    const double dx = curve.x[k1] - curve.x[k0];
    const double dy = curve.y[k1] - curve.y[k0];
    const bool horizontal = std::fabs(dx) >= std::fabs(dy);
    for (int32_t o = -band_px; o <= band_px; ++o) visit(horizontal ? cx : cx + o, horizontal ? cy + o : cy);
  }
}

// Four floats in one vector register (SSE, NEON, AltiVec; plain code elsewhere): GCC/Clang vector extension.
// Loaded by memcpy (unaligned) and never passed or returned by value (no vector ABI on a 750 PowerPC).
typedef float Float4 __attribute__((vector_size(16)));

// Scores of the positions x = lo..hi of line y (windows inside the image) into out[0..hi-lo]: nccAt's value.
// tb: the template, each pixel in all four lanes.
void scoreLine(const NccTemplate& t, const Float4* tb, const ImageView& image, int32_t y, int32_t lo, int32_t hi,
               CurveSearchScratch& s, double* out) {
  constexpr int32_t kChunk = CurveSearchScratch::kChunk;
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
  const double var_t = nccTemplateVariance(t);
  int32_t ws = 0, ws2 = 0;  // window sums by a running sum of the column sums
  for (int32_t i = 0; i < kNccSide - 1; ++i) {
    ws += s.column_sum[i];
    ws2 += s.column_sum_sq[i];
  }
  for (int32_t i0 = 0; i0 < n; i0 += kChunk) {
    // The cross products of 16 neighbouring positions, four 4-float vectors (integer products summed in
    // float: exact, every partial sum is an integer below 2^24).
    Float4 a0 = {}, a1 = {}, a2 = {}, a3 = {};
    for (int32_t r = 0; r < kNccSide; ++r) {
      const float* line = s.lines[r] + i0;
      const Float4* tr = tb + r * kNccSide;
      for (int32_t u = 0; u < kNccSide; ++u) {
        const Float4 tv = tr[u];
        Float4 v[4];
        std::memcpy(v, line + u, sizeof v);
        a0 += tv * v[0];
        a1 += tv * v[1];
        a2 += tv * v[2];
        a3 += tv * v[3];
      }
    }
    float acc[kChunk];
    std::memcpy(acc, &a0, sizeof a0);
    std::memcpy(acc + 4, &a1, sizeof a1);
    std::memcpy(acc + 8, &a2, sizeof a2);
    std::memcpy(acc + 12, &a3, sizeof a3);
    const int32_t end = i0 + kChunk < n ? i0 + kChunk : n;
    for (int32_t i = i0; i < end; ++i) {
      ws += s.column_sum[i + kNccSide - 1];
      ws2 += s.column_sum_sq[i + kNccSide - 1];
      out[i] = nccFromSums(t, var_t, ws, ws2, static_cast<double>(acc[i - i0]));
      ws -= s.column_sum[i];
      ws2 -= s.column_sum_sq[i];
    }
  }
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
  // 1. The x interval of the searched positions on every line.
  int32_t y_lo = h, y_hi = -1;
  for (int32_t y = 0; y < h; ++y) {
    scratch.line_lo[y] = w;
    scratch.line_hi[y] = -1;
  }
  forEachCurvePosition(curve, band_px, [&](int32_t x, int32_t y) {
    if (!inside_window(x, y)) return;
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
  Float4 tb[kNccPixels];
  for (int32_t i = 0; i < kNccPixels; ++i) {
    const float v = static_cast<float>(t.pixels[i]);
    tb[i] = Float4{v, v, v, v};
  }
  for (int32_t y = y_lo; y <= y_hi; ++y) {
    if (scratch.line_hi[y] < scratch.line_lo[y]) continue;
    scoreLine(t, tb, target, y, scratch.line_lo[y], scratch.line_hi[y], scratch, scratch.score + scratch.line_offset[y]);
  }
  // 3. The best and second peak in the search order.
  forEachCurvePosition(curve, band_px, [&](int32_t x, int32_t y) {
    if (!inside_window(x, y)) return;
    considerScore(hit, scratch.score[scratch.line_offset[y] + x - scratch.line_lo[y]], x, y);
  });
  return hit;
}

}  // namespace areomap
