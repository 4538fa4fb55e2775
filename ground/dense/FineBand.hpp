// The fine pass of the dense matcher (DenseMatcher.hpp, step 3): each pixel's band of candidate
// disparities about the coarse result, and the census costs over it.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "ground/dense/DenseMatcher.hpp"
#include "ground/dense/SemiGlobal.hpp"

namespace areomap::dense {

// The census distance of a right pixel outside the image: every bit of the census window differs.
inline constexpr uint16_t kCensusNoMatchCost = kCensusWindowCols * kCensusWindowRows - 1;

// Fine band per pixel: min..max of the coarse disparities of the 4x4 nodes around it, +- the margin, within
// the options' disparities and the image. `no_band` marks the pixels where that leaves nothing, and those
// outside `mask` (when not empty): they keep a band of one disparity that never matches.
BandVolume fineBand(const cv::Mat& coarse, int rows, int cols, const DenseOptions& o, const cv::Mat& mask,
                    std::vector<uint8_t>& no_band);

// The census cost of every pixel and disparity of the fine band: the Hamming distances of the census
// vectors summed over the (2 h + 1)^2 block about the pixel at that disparity (h = block_half_px; borders
// replicated, right pixels outside the image cost kCensusNoMatchCost), divided by the block's area and
// rounded, so the cost keeps the one-window scale (0..62 bits) that the penalties and the census-cost test
// are set in.
// One window's distance counts the bits that differ between a pair of near-equal grey levels as often as
// the bits of real structure, and flips with sensor noise and compression; summed over the block, a correct
// match's cost varies less, as in the coarse pass, which sums over its cell.
// Per row: the sums over the block's rows (V) for each column over the union of the bands of the pixels
// whose block holds that column, then each pixel's sum of V over its block's columns.
void fineCosts(const cv::Mat& cl, const cv::Mat& cr, const std::vector<uint8_t>& no_band, int block_half_px,
               BandVolume& v);

}  // namespace areomap::dense
