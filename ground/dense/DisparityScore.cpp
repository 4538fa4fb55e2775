#include "ground/dense/DisparityScore.hpp"

#include <cmath>
#include <stdexcept>

namespace areomap::dense {

DisparityScore scoreDisparity(const cv::Mat& disparity, const cv::Mat& truth, const cv::Mat& mask,
                              double threshold_px) {
  if (disparity.type() != CV_32FC1 || truth.type() != CV_32FC1 || disparity.size() != truth.size() ||
      (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != truth.size()))) {
    throw std::invalid_argument("scoreDisparity: CV_32F disparity and truth (and CV_8U mask) of one size");
  }
  DisparityScore s;
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) {
      const float t = truth.at<float>(y, x);
      if (!(t > 0.0f) || (!mask.empty() && mask.at<uint8_t>(y, x) == 0)) continue;
      ++s.evaluated;
      const float d = disparity.at<float>(y, x);
      if (!std::isfinite(d)) continue;
      ++s.matched;
      if (std::abs(d - t) > threshold_px) ++s.bad;
    }
  }
  return s;
}

}  // namespace areomap::dense
