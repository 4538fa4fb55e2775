// Dense coarse-to-fine matching of a rectified (epipolar) pair, paper §4.1:
//  1. per-row parallax ranges: from a parallax curve fitted to verified tie points (ParallaxCurve.hpp), or
//     the whole [min, max] range when there are none;
//  2. coarse matching on a 5-px grid inside those ranges (census cost summed over the 5x5 cell,
//     semi-global aggregation over the grid);
//  3. fine matching on the 1-px grid in a small range around the coarse result (min..max of the coarse
//     disparities of the 4x4 surrounding grid nodes, +- a margin), census cost + semi-global aggregation;
//  4. uniqueness and left-right consistency checks, a fill pass over a block for the pixels they refuse
//     (BlockFill.hpp), speckle removal, and a validity mask;
//  5. sub-pixel disparities by least-squares matching (SubpixelRefine.hpp) from the integer winner and the
//     parabola through its aggregated costs.
// Rows of a rectified pair are epipolar lines, so every search is restricted to the epipolar line.
// Disparity d is positive: left pixel (x, y) matches right pixel (x - d, y).
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "ground/dense/ParallaxCurve.hpp"
#include "ground/dense/SemiGlobal.hpp"
#include "ground/dense/SubpixelRefine.hpp"

namespace areomap::dense {

// Standard deviation (px) of a fine match's position, propagated into each point's covariance through the
// intersection (Triangulation.hpp, all four image coordinates), for a pair whose own estimate
// (MatchNoise.hpp) has too few samples: calibrated against truth on the navcam preset
// (tests/ground/products/NavcamAccuracyTest.cpp, PointSigmaAgainstTruth).
inline constexpr double kMatchSigmaPx = 0.15;

// Correlation length (px) of the fine matcher's disparity errors in the image: rho(lag) = exp(-lag / L)
// between two pixels' errors (census window + semi-global aggregation share the evidence of nearby
// pixels). Measured on a synthetic pair with a known sub-pixel disparity field, a plane with relief
// (tests/ground/dense/MatchErrorCorrelationTest.cpp: the integral scale of the autocorrelation of the errors,
// 1.67 px along rows and 2.44 px along columns). The DEM's sigma (ground/dem/Kriging.hpp) averages the
// errors with it.
inline constexpr double kMatchErrorCorrelationPx = 2.0;

// The census window (columns x rows, odd): a pixel's match rests on the grey values within it.
inline constexpr int kCensusWindowCols = 9;
inline constexpr int kCensusWindowRows = 7;

struct DenseOptions {
  int min_disparity_px = 0;
  int max_disparity_px = 64;       // inclusive
  int coarse_step_px = 5;          // the coarse grid (paper: 5 px)
  int fine_margin_px = 2;          // fine band = coarse min..max of the neighbourhood +- this
  // The fine cost of a pixel: the census distances summed over this odd block about it (1: the pixel's
  // own). A larger block (5: the coarse cell's support) gives denser, more left-right consistent matches on
  // noisy real images, but its errors are correlated over a longer distance than kMatchErrorCorrelationPx
  // and the left-right disagreement (MatchNoise.hpp) no longer sees all of them: the point and DEM sigmas
  // are calibrated for 1.
  int fine_block_px = 1;
  // The fill pass (BlockFill.hpp): pixels left without a match whose block has texture are matched again
  // over this odd block (0: off), with the one-pixel pass's tests on the block's cost. Its matches form a
  // class of their own (DenseResult::block) with their own left-right differences (block_lr_diff_px), from
  // which the pair's cloud gives them their own noise estimate (PairCloud::block_noise).
  int fill_block_px = 9;
  SemiGlobalParams coarse_sgm{8, 64, 8};
  SemiGlobalParams fine_sgm{8, 96, 8};
  int uniqueness_percent = 5;      // best must beat every non-adjacent candidate by this much
  int min_texture_grey = 3;        // pixels whose 9x7 window spans fewer grey levels are not matched
  // A match whose own 9x7 census cost (Hamming distance of 62 bits) exceeds this is not one: two unrelated
  // windows differ in Binomial(62, 1/2) bits, mean 31, sd 3.9, and 23 is 2 sd below that mean (chance
  // 2.8 %). Without it, semi-global aggregation carries disparities into the sky and into the part of the
  // left image that the right one does not see (points metres off at the far range).
  int max_census_cost_bits = 23;
  double lr_max_diff_px = 1.0;     // left-right consistency tolerance
  // Connected disparity blobs (neighbours within speckle_max_step_px) smaller than this are removed (-1: a
  // 2000th of the image). The values of OpenCV's StereoSGBM as its documentation advises them (window 50-200
  // px, range 1-2 px) and as the real-pair benchmark runs it, so that both matchers' densities count the
  // same.
  int speckle_max_area_px = 100;
  double speckle_max_step_px = 2.0;
  bool refine_subpixel = false;  // least-squares matching (SubpixelRefine.hpp); false: the parabola's
  SubpixelOptions subpixel;
  bool fill_holes = false;         // fill LR-check failures: occlusions from the background side,
                                   // mismatches from their neighbours (marked in `filled`)
};

struct DenseResult {
  cv::Mat disparity;  // CV_32F, left image geometry; NaN = no match
  cv::Mat valid;      // CV_8U, 255 where disparity is a match (or a filled value, see `filled`)
  cv::Mat filled;     // CV_8U, 255 where the value was filled rather than matched
  cv::Mat block;      // CV_8U, 255 where the match is the fill pass's block match (fill_block_px)
  cv::Mat coarse;     // CV_32F, the coarse-grid disparities (grid rows x grid cols)
  cv::Mat sigma_px;   // CV_32F, least-squares matching's a-posteriori sd per match (empty without it)
  // CV_32F: where a match passed the left-right check, its parabola sub-pixel disparity less the right
  // image's at the matched right pixel (from the same aggregated costs); NaN elsewhere. The input of the
  // pair's matching-noise estimate (MatchNoise.hpp). Refers to the parabola's disparities, also when
  // least-squares matching replaces them.
  cv::Mat lr_diff_px;  // of the one-pixel matches only
  cv::Mat block_lr_diff_px;  // the same for the block matches (BlockFill.hpp), from their block costs
  // CV_32F: at every sixth pixel (rows and columns) of the one-pixel matches, the fill pass's block disparity
  // less the one-pixel one (blockCheck); NaN elsewhere. The block class's noise (PairCloud::block_noise).
  cv::Mat block_check_px;
  SubpixelStats subpixel;
  double coarse_seconds = 0.0;
  double fine_seconds = 0.0;  // the fine pass, its fill pass included
  double fill_seconds = 0.0;  // the fill pass
  double post_seconds = 0.0;  // speckles, sub-pixel refinement, holes
  long long fine_cells = 0;   // size of the fine banded volume (pixels x candidates)
  double matched_fraction = 0.0;  // valid pixels / all pixels
};

// Matches a rectified pair (8-bit grey, same size). `row_ranges` (optional, one per row, e.g. from
// parallaxRowRanges) restricts the coarse search. `mask` (optional, CV_8U of the images' size): only its
// non-zero pixels are matched (the rest cost one candidate each in the fine pass and get no match; the
// semi-global paths start afresh where they enter it), e.g. the rectified pixels that show the original.
// Throws std::invalid_argument on bad input.
DenseResult matchRectified(const cv::Mat& left, const cv::Mat& right, const DenseOptions& options,
                           const std::vector<RowRange>* row_ranges = nullptr, const cv::Mat& mask = cv::Mat());

// Census transform, 9x7 window (62 bits), borders replicated. Exposed for tests.
cv::Mat censusTransform(const cv::Mat& image);

}  // namespace areomap::dense
