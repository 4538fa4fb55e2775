// The parallax curve of paper §4.1: the x-parallax (disparity) of verified tie points of a rectified pair
// as a smooth function of the row, and per-row parallax ranges around it that the coarse matching
// searches.
#pragma once

#include <vector>

namespace areomap::dense {

struct TieDisparity {
  double x_px = 0.0;  // left image, rectified
  double y_px = 0.0;
  double disparity_px = 0.0;  // x_left - x_right
};

struct RowRange {
  int lo = 0;
  int hi = 0;  // inclusive
};

struct ParallaxCurve {
  double c0 = 0.0, c1 = 0.0, c2 = 0.0;  // d(y) = c0 + c1 t + c2 t^2, t = y / rows
  double sigma_px = 0.0;                 // RMS residual of the inliers
  int inliers = 0;
  double at(double y_px, int rows) const {
    const double t = y_px / rows;
    return c0 + c1 * t + c2 * t * t;
  }
};

// Robust least-squares fit (3-sigma rejection, a few rounds). Needs >= 3 ties; fewer gives a constant.
ParallaxCurve fitParallaxCurve(const std::vector<TieDisparity>& ties, int rows);

// Per-row ranges: the curve +- (the largest inlier |residual| of ties within `window_rows` of the row,
// at least 3 sigma) +- margin, clipped to [min_px, max_px]. Rows without nearby ties use the global
// largest residual. Empty `ties` give [min_px, max_px] everywhere.
std::vector<RowRange> parallaxRowRanges(const std::vector<TieDisparity>& ties, int rows, int min_px,
                                        int max_px, int margin_px = 4, int window_rows = 64);

}  // namespace areomap::dense
