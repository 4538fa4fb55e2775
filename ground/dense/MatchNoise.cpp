#include "ground/dense/MatchNoise.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace areomap::dense {

namespace {

// sigma of a Gaussian from its median absolute deviation.
constexpr double kMadToSigma = 1.4826;

double median(std::vector<float>& v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

MatchNoise estimateMatchNoise(const cv::Mat& lr_diff_px, double fallback_sigma_px) {
  if (!lr_diff_px.empty() && lr_diff_px.type() != CV_32FC1)
    throw std::invalid_argument("match noise: the left-right differences must be CV_32F");
  std::vector<float> d;
  for (int y = 0; y < lr_diff_px.rows; ++y) {
    const float* row = lr_diff_px.ptr<float>(y);
    for (int x = 0; x < lr_diff_px.cols; ++x) {
      if (std::isfinite(row[x])) d.push_back(row[x]);
    }
  }
  MatchNoise out;
  out.samples = static_cast<long long>(d.size());
  if (!d.empty()) {
    const double m = median(d);
    for (float& v : d) v = static_cast<float>(std::fabs(v - m));
    out.lr_sigma_px = kMadToSigma * median(d) / std::sqrt(2.0);
  }
  if (out.samples >= kMinMatchNoiseSamples) {
    out.sigma_px = out.lr_sigma_px;
    out.source = "left_right";
  } else {
    out.sigma_px = fallback_sigma_px;
    out.source = "fallback_constant";
  }
  return out;
}

}  // namespace areomap::dense
