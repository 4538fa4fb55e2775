// The square-window search of a template warped by a local affine map (the inter-stereo ties of
// PanoramaMatcher: the offset probe and the search around the corrected prediction) and its sub-pixel peak.
// The window's centres share one WarpedSamples grid; four neighbouring centres are scored at once, each
// with nccWarpedAt's operations in nccWarpedAt's order, so that every score equals nccWarpedAt's bit for
// bit (searchWindowWarpedDirect is that reference). No heap.
#pragma once

#include <cstdint>

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/ImageView.hpp"
#include "firmware_core/match/EpipolarSearch.hpp"
#include "firmware_core/match/Ncc.hpp"

namespace areomap {

// Caller-owned scratch of searchWindowWarped (~140 KiB; make it static): the sample grid, the image under
// the search as doubles, and one line of scores.
struct WarpedSearchScratch {
  // Warps that reach up to this far from the window's centre use the region; wider ones nccWarpedAt.
  static constexpr int32_t kMaxReachPx = 16;
  static constexpr int32_t kSide = 2 * kInterOffsetSearchRadiusPx + 1 + 2 * kMaxReachPx + 2;
  WarpedSamples samples;
  int32_t offset[kNccPixels];
  double region[kSide * kSide];
  double score[2 * kInterOffsetSearchRadiusPx + 1];
};

// Best NCC of `t`, warped by `a` (nccWarpedAt; identity = plain NCC), in the square window +-radius around
// (cx, cy) (radius <= kInterOffsetSearchRadiusPx), the second peak as searchAlongCurve has it; centres in
// rows (y outer, x inner).
SearchHit searchWindowWarped(const NccTemplate& t, const ImageView& target, int32_t cx, int32_t cy,
                             int32_t radius, const Mat2& a, WarpedSearchScratch& scratch);
// The same search with nccWarpedAt at every centre.
SearchHit searchWindowWarpedDirect(const NccTemplate& t, const ImageView& target, int32_t cx, int32_t cy,
                                   int32_t radius, const Mat2& a);
// The sub-pixel peak about the integer maximum (bx, by) of the warped search (parabolas in x and y).
void refinePeakWarped(const NccTemplate& t, const ImageView& image, int32_t bx, int32_t by, double best,
                      const Mat2& a, double& x_px, double& y_px);

}  // namespace areomap
