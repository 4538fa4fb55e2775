// Semi-global aggregation (Hirschmüller 2008) over a banded cost volume: every pixel has its own contiguous
// run of candidate disparities [lo, lo + count), which is how the coarse-to-fine search (paper §4.1)
// restricts the fine 1-px search to a small range around the coarse result.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace areomap::dense {

struct BandVolume {
  int rows = 0;
  int cols = 0;
  std::vector<int32_t> lo;      // rows * cols: first disparity of the pixel's band
  std::vector<int32_t> count;   // rows * cols: band length (>= 1)
  std::vector<int64_t> offset;  // rows * cols + 1: start of the pixel's band in `cost`
  std::vector<uint16_t> cost;   // matching cost per (pixel, disparity)

  // Fills `offset` from `count` and sizes `cost`.
  void finishLayout();
  int64_t cells() const { return offset.empty() ? 0 : offset.back(); }
};

// Bounds of the matching costs and of the penalties, so that every path cost and their sum over 8 paths fit
// 16-bit lanes (the aggregation steps 8 disparities at a time). The census costs are at most 62 bits.
inline constexpr int kMaxSemiGlobalCost = 2047;
inline constexpr int kMaxSemiGlobalPenalty = 2047;

struct SemiGlobalParams {
  int p1 = 8;     // penalty of a 1-px disparity step between neighbours
  int p2 = 96;    // penalty of a larger step, reduced across intensity edges
  int paths = 8;  // 4 (horizontal, vertical) or 8 (plus diagonals)
};

// Sums the path costs of all paths into `sum` (same layout as volume.cost). `guide` (CV_8U, rows x cols)
// lowers P2 across intensity edges: P2' = max(P1 + 1, P2 * 16 / (16 + |dI|)). Throws std::invalid_argument
// on a cost above kMaxSemiGlobalCost or a penalty outside 0..kMaxSemiGlobalPenalty.
void aggregateSemiGlobal(const BandVolume& volume, const cv::Mat& guide, const SemiGlobalParams& params,
                         std::vector<uint16_t>& sum);

}  // namespace areomap::dense
