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

struct SemiGlobalParams {
  int p1 = 8;         // penalty of a 1-px disparity step between neighbours
  int p2 = 96;        // penalty of a larger step, reduced across intensity edges
  int paths = 8;      // 4 (horizontal, vertical) or 8 (plus diagonals)
};

// Sums the path costs of all paths into `sum` (same layout as volume.cost). `guide` (CV_8U, rows x cols)
// lowers P2 across intensity edges: P2' = max(P1 + 1, P2 * 16 / (16 + |dI|)).
void aggregateSemiGlobal(const BandVolume& volume, const cv::Mat& guide, const SemiGlobalParams& params,
                         std::vector<uint16_t>& sum);

}  // namespace areomap::dense
