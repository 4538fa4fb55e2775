// Scores a disparity map against ground truth the Middlebury way: over the evaluated pixels (truth known
// and, when a mask is given, non-occluded), `density` = fraction with a disparity, `bad` = fraction of
// those with |d - truth| > threshold.
#pragma once

#include <opencv2/core.hpp>

namespace areomap::dense {

struct DisparityScore {
  long long evaluated = 0;   // pixels with known truth (and in the mask)
  long long matched = 0;     // of those, with a finite disparity
  long long bad = 0;         // of the matched, error above the threshold
  double density() const { return evaluated ? static_cast<double>(matched) / evaluated : 0.0; }
  double badRate() const { return matched ? static_cast<double>(bad) / matched : 0.0; }
  // Bad or missing, over all evaluated pixels.
  double badOrMissingRate() const {
    return evaluated ? static_cast<double>(bad + evaluated - matched) / evaluated : 0.0;
  }
};

// disparity: CV_32F (NaN = none); truth: CV_32F (<= 0 = unknown); mask: CV_8U (non-zero = evaluate) or empty.
DisparityScore scoreDisparity(const cv::Mat& disparity, const cv::Mat& truth, const cv::Mat& mask,
                              double threshold_px = 1.0);

}  // namespace areomap::dense
