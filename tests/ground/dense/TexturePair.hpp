// A rectified pair rendered from one continuous texture with a known disparity field, for the dense
// matcher's accuracy tests (MatchErrorCorrelationTest, GrazingPlaneBiasTest).
#pragma once

#include <opencv2/imgproc.hpp>

namespace areomap::test {

// `tex` (CV_32F) is the texture with a margin of `pad` pixels on every side. left(x, y) = tex(x, y) and
// right(x, y) = tex(texture_x(x, y), y), in unpadded texture coordinates, bicubic. The images stay CV_32F
// (w x h) so that a test can fade or add noise before it converts them to 8 bit.
template <class TextureX>
void remapPair(const cv::Mat& tex, int pad, int w, int h, const TextureX& texture_x, cv::Mat& left, cv::Mat& right) {
  cv::Mat lx(h, w, CV_32FC1), rx(h, w, CV_32FC1), my(h, w, CV_32FC1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      lx.at<float>(y, x) = static_cast<float>(x + pad);
      rx.at<float>(y, x) = static_cast<float>(texture_x(x, y) + pad);
      my.at<float>(y, x) = static_cast<float>(y + pad);
    }
  }
  cv::remap(tex, left, lx, my, cv::INTER_CUBIC, cv::BORDER_REFLECT);
  cv::remap(tex, right, rx, my, cv::INTER_CUBIC, cv::BORDER_REFLECT);
}

// `w` x `h` pixels of a uniform random texture (grey 0..255 from `rng`, Gaussian blur of blur_px, a margin
// of `pad`) seen with the disparity field d(x, y) of the LEFT pixels: left(x, y) = T(x, y), right(xr, y) =
// T(x, y) where x - d(x, y) = xr (solved by fixed point from x = xr + d(xr, y): |dd/dx| must stay well
// below 1). CV_32F, for the caller's noise before it converts to 8 bit.
template <class Disparity>
void texturedDisparityPair(cv::RNG& rng, int w, int h, int pad, double blur_px, const Disparity& d,
                           cv::Mat& left, cv::Mat& right) {
  cv::Mat tex(h + 2 * pad, w + 2 * pad, CV_32FC1);
  rng.fill(tex, cv::RNG::UNIFORM, 0.0, 255.0);
  cv::GaussianBlur(tex, tex, cv::Size(0, 0), blur_px);
  remapPair(
      tex, pad, w, h,
      [&](int xr, int y) {
        double x = xr + d(xr, y);
        for (int k = 0; k < 30; ++k) x = xr + d(x, y);
        return x;
      },
      left, right);
}

}  // namespace areomap::test
