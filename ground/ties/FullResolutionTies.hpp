// Tie points on frames of any size with the rover's fixed-capacity matcher (firmware_core/match
// PanoramaMatcher, images up to kMaxImageWidth x kMaxImageHeight). The rover's capacity is the rover's bound,
// not the ground's, so the ground matches a larger panorama in two steps:
//   1. binning: every image is reduced by the smallest integer factor k that brings the largest image of
//      the panorama within the matcher's capacity (k x k box mean; the last W mod k columns and H mod k
//      lines, which no whole bin covers, are left out), and every model is rescaled EXACTLY to that pixel
//      frame (binnedModel: a binned pixel's centre is the full-resolution point k b + (k - 1) / 2).
//      The matcher then runs unchanged: the same epipolar search, left-right and parallax checks, gridding
//      and inter-stereo ties, each 11 x 11 template covering k x 11 full-resolution pixels;
//   2. refinement: each tie point's first observation (the left image of the pair that found it) is taken
//      to the nearest full-resolution pixel, and every other observation of the point is matched again at
//      full resolution to that pixel's template of k x 11 pixels a side (the surface the binned template
//      compared, now at full detail): normalised correlation at every integer offset within k + 1 pixels of
//      the binned match mapped up, its sub-pixel peak, the match searched back (it must land within the
//      matcher's left-right tolerance of the template's pixel), then least-squares matching with an affine
//      map and a radiometric gain and offset from that peak (the foreshortening between the views over a
//      template of k x 11 pixels biases a plain correlation peak by tenths of a pixel at near range). An
//      observation whose peak lies on the search window's border (the binned match was not the same surface
//      point), scores below the floor (the matcher's min_ncc, lowered to what the full-resolution scores of
//      this run show for the same surfaces: median - 4 robust sd), fails the back-match or whose
//      least-squares fit does not converge near the peak is left out, and a point left with fewer than two
//      observations is left out whole.
// Binning rather than windows of the full frame keeps one matcher run over the whole frame (one parallax
// curve, one gridding, inter-stereo prediction through one coarse DEM per pair) and every tie at full
// resolution precision; with k = 1 (every image within capacity) nothing is binned or refined.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "firmware_core/camera/Binning.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "firmware_core/match/TieList.hpp"

namespace areomap {

// The binning factor, the binned model and the full-resolution position of a binned pixel:
// binningFactor, binnedModel, fullResolutionPx (firmware_core/camera/Binning.hpp, shared with the rover).

// The image binned by k (k x k box mean, rounded), floor(cols / k) x floor(rows / k); the image itself (no
// copy) for k = 1.
cv::Mat binImage(const cv::Mat& grey, int32_t k);

struct RefineParams {
  double min_ncc = 0.8;         // the matcher's (StereoParams::min_ncc)
  int32_t lr_tolerance_px = 1;  // the matcher's (StereoParams::lr_tolerance_px)
};

struct RefineCounts {
  int32_t refined = 0;         // observations matched again at full resolution
  int32_t dropped = 0;         // observations left out, of which:
  int32_t low_score = 0;       // the correlation peak scored below score_floor (or its window left the image)
  int32_t border = 0;          // the peak lay on the search window's border
  int32_t back_match = 0;      // the match searched back missed the template's pixel
  int32_t least_squares = 0;   // the least-squares fit did not converge near the peak
  int32_t points_dropped = 0;  // points left with fewer than two observations
  double score_floor = 0.0;    // the correlation floor used (from the data, at most min_ncc)
};

// Step 2 above. `observations` and `points` are the matcher's list in binned pixels (TieList order: every
// observation's point an index into `points`); `images[i]` is the full-resolution image of tie image index
// i (2 * pair + side; an empty Mat for an absent right image). On return both lists are in full-resolution
// pixels, the left-out observations and points removed and the point indices renumbered (the order of what
// is kept unchanged, so a prefix of the input lists maps to a prefix of the output; `kept_prefix[n]` is the
// output length of the first n input observations, n = 0..input size, and `kept_points[n]` likewise).
RefineCounts refineAtFullResolution(const std::vector<cv::Mat>& images, int32_t k, const RefineParams& params,
                                    std::vector<TieObservation>& observations, std::vector<TiePoint>& points,
                                    std::vector<int32_t>& kept_prefix, std::vector<int32_t>& kept_points);

}  // namespace areomap
