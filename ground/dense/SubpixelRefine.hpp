// Sub-pixel disparity by least-squares matching (Gruen's adaptive least-squares correlation, restricted to
// the epipolar line of a rectified pair): the semi-global matcher's winner is an integer disparity, and a
// parabola through its three aggregated costs puts it between pixels with an error that depends on the
// disparity's fractional part ("pixel locking", up to +-0.16 px on a textured plane, most of the matcher's
// error there; tests/ground/dense/SubpixelRefineTest.cpp). That error changes only as slowly as the
// fractional part does, so on smooth ground it is correlated over tens of pixels and does not average down
// in a DEM cell. Least-squares matching fits the left window to the right image resampled at the window's
// own disparity, so it has no such preference for whole pixels.
//
// The model, for the window of (2 half_width + 1) x (2 half_height + 1) left pixels about (x, y):
//   L(x + i, y + j) = a + b R(x + i - (d + gx i + gy j), y + j)
// d the disparity at the centre, gx and gy its gradient over the window (slanted ground: at near range the
// disparity changes by ~0.13 px per row), a and b the radiometric offset and gain; R resampled by cubic
// convolution (Keys, a = -1/2) along the row. Gauss-Newton from the matcher's disparity with a = 0, b = 1,
// gx = gy = 0. The a-posteriori standard deviation of d (sigma0^2 (N^-1)_dd) is returned per pixel.
#pragma once

#include <opencv2/core.hpp>

namespace areomap::dense {

struct SubpixelOptions {
  int half_width = 4;   // 9 columns (the census window's)
  int half_height = 3;  // 7 rows
  int max_iterations = 8;
  double converged_px = 0.01;  // |step of d| below this: converged (the error left is ~its square)
  double max_shift_px = 1.0;   // farther from the matcher's disparity: not the same match (not refined)
  double min_gain = 0.25, max_gain = 4.0;  // b outside: not a match of the same surface (not refined)
};

struct SubpixelStats {
  long long refined = 0;  // converged
  long long kept = 0;     // not refined, the matcher's disparity kept: window outside the image,
                          // singular (no texture along the row), moved too far, no convergence
};

// Refines disparity (CV_32F) in place where valid (CV_8U) is set; where the fit fails the matcher's value
// stays (SubpixelStats::kept). left/right: the rectified pair (CV_8U).
// sigma_px (may be null): CV_32F, the a-posteriori standard deviation of each refined disparity, NaN
// elsewhere. Rows are refined in parallel; the result does not depend on the number of threads.
SubpixelStats refineSubpixel(const cv::Mat& left, const cv::Mat& right, cv::Mat& disparity,
                             const cv::Mat& valid, const SubpixelOptions& options,
                             cv::Mat* sigma_px = nullptr);

}  // namespace areomap::dense
