// The fill pass of the dense matcher (DenseMatcher.hpp, DenseOptions::fill_block_px): pixels that the
// one-pixel pass leaves without a match (refused by the left-right, uniqueness or census-cost test) are
// matched again by winner-takes-all over the census cost summed over a block about the pixel, inside the
// pixel's fine band, with the same tests on that cost. On compressed, low-contrast real images the one-pixel
// census cost is noisy and its winners often disagree between the views; the block's cost is not, but its
// errors are correlated over the block and it smooths relief, so its matches are a class of their own: they
// are flagged (DenseResult::block) and carry their own noise estimate (PairCloud::block_noise).
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "ground/dense/SemiGlobal.hpp"

namespace areomap::dense {

struct BlockFillParams {
  int block_half_px = 4;  // the block: (2 h + 1)^2 pixels
  // Its census windows are summed every stride_px-th pixel along rows and columns (h a multiple of it): a
  // 9x7 census window shares most of its support with its neighbours', so the sampled sum carries nearly
  // the block's evidence at a fraction of its cost.
  int stride_px = 2;
  int uniqueness_percent = 5;    // as DenseOptions
  int max_census_cost_bits = 23; // on the block's mean census distance
  double lr_max_diff_px = 1.0;
  int no_match_cost = 62;        // the census distance of a right pixel outside the image
};

// For every pixel where `candidate` (CV_8U) is non-zero: the block winner over its band of `v` (lo, count),
// the census vectors `cl`, `cr` (censusTransform). Where it passes the tests (unique, mean cost within
// the bound, the minimum inside the band, the right view's block winner at the matched pixel within
// lr_max_diff_px), `disparity` gets its parabola sub-pixel value, `valid` and `block` 255, and `lr_diff_px`
// the left sub-pixel disparity less the right view's (its parabola over the same block costs; NaN where it
// has none). Returns the number of pixels filled.
long long blockFill(const cv::Mat& cl, const cv::Mat& cr, const BandVolume& v, const cv::Mat& candidate,
                    const BlockFillParams& p, cv::Mat& disparity, cv::Mat& valid, cv::Mat& block,
                    cv::Mat& lr_diff_px);

// The class's noise from the pair's own data: its left-right disagreement misses the errors both views'
// block costs share (the block's smoothing of relief: on a textured pair with relief the block matches'
// left-right estimate falls well below their actual errors, tests/ground/dense/MatchNoiseTest.cpp), so the
// block winner is also found at every every_px-th pixel (rows and columns) of the one-pixel matches
// (`valid`, `disparity`), with the same tests on its left view. `check_px` (CV_32F) gets the block disparity
// less the one-pixel one there, NaN elsewhere: its spread holds both classes' errors where they are
// independent, an upper bound of the block class's.
void blockCheck(const cv::Mat& cl, const cv::Mat& cr, const BandVolume& v, const cv::Mat& valid,
                const cv::Mat& disparity, int every_px, const BlockFillParams& p, cv::Mat& check_px);

}  // namespace areomap::dense
