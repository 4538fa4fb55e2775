// The a-priori epipolar curve of a pixel: the ray of `pixel` in camera `from` sampled between a near and a
// far range (uniform in inverse range, so the samples are ~1 px apart in `to`) and projected into `to`
// with the full (distorted) model. The search runs along the curve and +-band pixels across it.
#pragma once

#include <cstdint>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/ImageView.hpp"
#include "firmware_core/base/Status.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "firmware_core/match/Ncc.hpp"

namespace areomap {

struct EpipolarCurve {
  float x[kMaxEpipolarSteps];
  float y[kMaxEpipolarSteps];
  int32_t count = 0;
  Vec2 far_px = Vec2::Zero();  // projection of the far end (parallax origin)
};

// kBehindCamera when no sample of the range projects into `to`; samples outside the image are dropped.
[[nodiscard]] Status epipolarCurve(const CameraModel& from, const CameraModel& to, const Vec2& pixel,
                                   double min_range_m, double max_range_m, int32_t to_width, int32_t to_height,
                                   EpipolarCurve& curve);

struct SearchHit {
  double score = kNccInvalid;
  int32_t x = 0;  // integer position of the best score
  int32_t y = 0;
  double second = kNccInvalid;  // best score at least 3 px away from the peak (ambiguity)
};

// A second peak counts only this far from the best one (in x or in y).
constexpr int32_t kAmbiguityDistancePx = 3;

// Takes score s at (x, y) into the hit, in the search order: the best score and its position, and the best
// score at least kAmbiguityDistancePx from the best position as it stood when that score was seen.
inline void considerScore(SearchHit& hit, double s, int32_t x, int32_t y) {
  if (s <= kNccInvalid) return;
  const bool far = x - hit.x >= kAmbiguityDistancePx || hit.x - x >= kAmbiguityDistancePx ||
                   y - hit.y >= kAmbiguityDistancePx || hit.y - y >= kAmbiguityDistancePx;
  if (s > hit.score) {
    if (far && hit.score > hit.second) hit.second = hit.score;
    hit.score = s;
    hit.x = x;
    hit.y = y;
  } else if (s > hit.second && far) {
    hit.second = s;
  }
}

// Scratch of searchAlongCurve (caller-owned, ~210 KiB): the curve's centres, the searched positions' x
// interval per image line, their scores, and the float copy of the 11 lines under one interval. Scores are
// computed a line at a time (the template's 121 products for 16 neighbouring positions at once, window sums
// by column sums; VectorKernels.hpp), then read in the search order, so the result equals nccAt at every
// position (the sums are integers below 2^24, exact in float).
struct CurveSearchScratch {
  // Enough for the default band (+-4 px: 9 x kMaxEpipolarSteps positions); beyond it nccAt per position.
  static constexpr int32_t kMaxScores = 16384;
  static constexpr int32_t kChunk = 16;         // positions per inner block
  static constexpr int32_t kRowFloats = kMaxImageWidth + kNccSide + kChunk;
  int32_t centre_x[kMaxEpipolarSteps];  // the curve's searched centres in the search order
  int32_t centre_y[kMaxEpipolarSteps];
  bool horizontal[kMaxEpipolarSteps];  // the band across the curve runs along y there
  int32_t line_lo[kMaxImageHeight];
  int32_t line_hi[kMaxImageHeight];
  int32_t line_offset[kMaxImageHeight];
  double score[kMaxScores];
  float lines[kNccSide][kRowFloats];
  int32_t column_sum[kRowFloats];
  int32_t column_sum_sq[kRowFloats];
};

// Best NCC of `t` along the curve within +-band_px across it (band_px <= kMaxEpipolarBandPx).
SearchHit searchAlongCurve(const NccTemplate& t, const ImageView& target, const EpipolarCurve& curve,
                           int32_t band_px, CurveSearchScratch& scratch);
// The same search with nccAt at every position (the reference of the line-wise one, and its fallback beyond
// CurveSearchScratch::kMaxScores positions).
SearchHit searchAlongCurveDirect(const NccTemplate& t, const ImageView& target, const EpipolarCurve& curve,
                                 int32_t band_px);

}  // namespace areomap
