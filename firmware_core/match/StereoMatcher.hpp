// Intra-stereo tie points of one pair (paper §3.4): Förstner points in the left image, NCC search in the
// right image along the a-priori epipolar curve within a range (parallax) interval and +-band pixels across
// it, sub-pixel peak, left-right consistency (the right match searched back along its own epipolar curve
// must land on the left point), verification by the parallax-versus-row curve, and final selection by
// gridding (the best verified match per grid cell of the left image). Zero heap: all buffers are in the
// caller-owned StereoWorkspace.
#pragma once

#include <cstdint>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/ImageView.hpp"
#include "firmware_core/base/Status.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "firmware_core/match/EpipolarSearch.hpp"
#include "firmware_core/match/ForstnerDetector.hpp"
#include "firmware_core/match/ParallaxVerifier.hpp"

namespace areomap {

struct StereoParams {
  ForstnerParams forstner;
  double min_range_m = 1.0;    // nearest surface searched (largest parallax)
  double max_range_m = 1000.0; // farthest (parallax origin, ~infinity)
  int32_t band_px = 4;         // across the a-priori epipolar curve
  double min_ncc = 0.8;
  double max_second_ratio = 0.98;  // reject when the second peak (>= 3 px away) scores this close to the best
  int32_t lr_tolerance_px = 1;     // left-right check: integer distance back to the left point
  ParallaxParams parallax;
  int32_t grid_cell_px = 0;    // final selection grid (cells <= kMaxTiesPerPair); 0: from tie_budget
  int32_t tie_budget = kMaxTiesPerPair;  // automatic grid: at most this many cells (a square number of them)
  int32_t min_ties = 8;        // fewer verified ties: kNoTexture
  StereoParams() {
    forstner.border_px = kNccRadius + 1;
    forstner.cell_px = 0;  // 0: 1/32 of the larger side (at least kMinSpreadingCellPx)
    // Half the image's mean w: the mean is dominated by the sharp far field, and a threshold at the mean
    // left the near-range strip at the bottom of a frame (the overlap with the tier below) with few points;
    // the spreading grid keeps only the best per cell anyway, and w_min still rejects blank images.
    forstner.w_mean_factor = 0.5;
  }
};

struct StereoMatch {
  Vec2 left_px = Vec2::Zero();   // integer left pixel (the template centre)
  Vec2 right_px = Vec2::Zero();  // sub-pixel right match
  double score = 0.0;            // NCC
  double parallax_px = 0.0;      // distance along the epipolar curve from the far-range projection
  bool verified = false;
};

struct StereoCounts {
  int32_t interest_points = 0;
  int32_t searched = 0;
  int32_t ncc_passed = 0;
  int32_t lr_passed = 0;
  int32_t parallax_passed = 0;
  int32_t selected = 0;
};

// After matchStereoPair, matches[0, match_count) are the left-right consistent matches (with the parallax
// verdict in `verified`) and cell_best[c] is the index of the match selected in grid cell c (-1: none):
// PanoramaMatcher keeps verified matches that were not selected as inter-stereo candidates.
struct StereoWorkspace {
  ForstnerWorkspace forstner;
  InterestPoint points[kMaxInterestPoints];
  StereoMatch matches[kMaxInterestPoints];
  int32_t match_count = 0;
  EpipolarCurve curve;
  CurveSearchScratch search;
  float rows[kMaxInterestPoints];
  float parallax[kMaxInterestPoints];
  bool inlier[kMaxInterestPoints];
  double scratch[kMaxInterestPoints];
  int32_t cell_best[kMaxTiesPerPair];
};

struct StereoResult {
  StereoMatch ties[kMaxTiesPerPair];  // selected ties, in grid-cell order
  int32_t tie_count = 0;
  StereoCounts counts;
  ParallaxCurve curve;
};

// The effective selection grid and Förstner spreading grid for an image size (the automatic values when
// the parameters hold 0: the selection grid has floor(sqrt(tie_budget)) cells along the larger side, at
// least 16 px; the spreading grid 32 cells, at least kMinSpreadingCellPx).
int32_t selectionGridPx(const StereoParams& params, int32_t width, int32_t height);
int32_t spreadingGridPx(const StereoParams& params, int32_t width, int32_t height);

// How far matchAlongCurve got.
enum class CurveMatchStage { kNoCurve, kNoMatch, kNoBackMatch, kMatched };

// The template `t` of `from` at from_px searched along its epipolar curve in `to` (surface ranges lo_m to
// hi_m, params.band_px across): the best hit must score params.min_ncc and stand clear of the second peak
// (params.max_second_ratio), and the window there, searched back along its own curve in `from`, must land
// within back_tolerance_px of from_px in x and y (left-right check). `hit`: the integer match; `far_px`: the
// curve's far-range end (the parallax origin). Uses the workspace's curve and search scratch.
CurveMatchStage matchAlongCurve(const NccTemplate& t, const ImageView& from, const ImageView& to,
                                const CameraModel& from_model, const CameraModel& to_model,
                                const Vec2& from_px, double lo_m, double hi_m, const StereoParams& params,
                                double back_tolerance_px, StereoWorkspace& workspace, SearchHit& hit,
                                Vec2& far_px);

// kNoTexture for a blank, saturated or noise-only pair (too few interest points or verified matches);
// kInvalidArgument for bad views or parameters; kCapacityExceeded for oversized images or grids.
[[nodiscard]] Status matchStereoPair(const ImageView& left, const ImageView& right, const CameraModel& left_model,
                                     const CameraModel& right_model, const StereoParams& params,
                                     StereoWorkspace& workspace, StereoResult& result);

}  // namespace areomap
