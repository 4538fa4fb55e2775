#include "ground/products/Previews.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

namespace areomap::products {

namespace {

double roundLength(double target) {
  const double p = std::pow(10.0, std::floor(std::log10(target)));
  for (double m : {5.0, 2.0, 1.0}) {
    if (m * p <= target) return m * p;
  }
  return p;
}

std::string lengthText(double m) {
  char buf[32];
  if (m >= 1.0) {
    std::snprintf(buf, sizeof buf, "%g m", m);
  } else {
    std::snprintf(buf, sizeof buf, "%g cm", m * 100.0);
  }
  return buf;
}

}  // namespace

void drawScaleBar(cv::Mat& image, double metres_per_px) {
  if (image.cols < 40 || image.rows < 30 || !(metres_per_px > 0)) return;
  const double len_m = roundLength(0.2 * image.cols * metres_per_px);
  const int len_px = std::max(1, static_cast<int>(std::lround(len_m / metres_per_px)));
  const int x0 = 10, y0 = image.rows - 12;
  cv::rectangle(image, cv::Point(x0 - 4, y0 - 22), cv::Point(x0 + len_px + 70, y0 + 8), cv::Scalar(255, 255, 255),
                cv::FILLED);
  cv::rectangle(image, cv::Point(x0, y0 - 4), cv::Point(x0 + len_px, y0 + 2), cv::Scalar(0, 0, 0), cv::FILLED);
  cv::putText(image, lengthText(len_m), cv::Point(x0 + len_px + 6, y0 + 3), cv::FONT_HERSHEY_SIMPLEX, 0.45,
              cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
}

cv::Mat demPreview(const DemGrid& dem) {
  cv::Mat z(dem.rows, dem.cols, CV_32F);
  cv::Mat valid(dem.rows, dem.cols, CV_8U);
  float lo = 1e30f, hi = -1e30f;
  for (int r = 0; r < dem.rows; ++r) {
    for (int c = 0; c < dem.cols; ++c) {
      const float v = dem.at(c, r);
      const bool ok = v != dem.nodata && std::isfinite(v);
      valid.at<uint8_t>(r, c) = ok ? 255 : 0;
      z.at<float>(r, c) = ok ? v : 0.f;
      if (ok) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
    }
  }
  if (lo > hi) lo = hi = 0.f;
  {
    // Robust stretch: 1st to 99th percentile of the heights.
    std::vector<float> h;
    for (int r = 0; r < dem.rows; ++r)
      for (int c = 0; c < dem.cols; ++c)
        if (valid.at<uint8_t>(r, c)) h.push_back(z.at<float>(r, c));
    if (h.size() > 100) {
      std::nth_element(h.begin(), h.begin() + h.size() / 100, h.end());
      lo = h[h.size() / 100];
      std::nth_element(h.begin(), h.begin() + h.size() * 99 / 100, h.end());
      hi = h[h.size() * 99 / 100];
    }
  }
  // Hillshade from the gradient (cells, so that the shading is independent of the colour stretch).
  cv::Mat gx, gy;
  cv::Sobel(z, gx, CV_32F, 1, 0, 3, 1.0 / (8.0 * dem.cell_m));
  cv::Sobel(z, gy, CV_32F, 0, 1, 3, 1.0 / (8.0 * dem.cell_m));
  const double az = 315.0 * M_PI / 180.0, el = 45.0 * M_PI / 180.0;
  // Sun direction in (east, south, up) image axes.
  const double sx = std::sin(az) * std::cos(el), sy = -std::cos(az) * std::cos(el), sz = std::sin(el);
  cv::Mat grey8(dem.rows, dem.cols, CV_8U);
  for (int r = 0; r < dem.rows; ++r) {
    for (int c = 0; c < dem.cols; ++c) {
      const double t = hi > lo ? (z.at<float>(r, c) - lo) / (hi - lo) : 0.5;
      grey8.at<uint8_t>(r, c) = static_cast<uint8_t>(std::clamp(t * 255.0, 0.0, 255.0));
    }
  }
  cv::Mat colour;
  cv::applyColorMap(grey8, colour, cv::COLORMAP_TURBO);
  for (int r = 0; r < dem.rows; ++r) {
    for (int c = 0; c < dem.cols; ++c) {
      cv::Vec3b& px = colour.at<cv::Vec3b>(r, c);
      if (!valid.at<uint8_t>(r, c)) {
        px = cv::Vec3b(255, 255, 255);
        continue;
      }
      // Surface normal (-dz/dx, -dz/dy, 1) with x east, y south.
      const double nx = -gx.at<float>(r, c), ny = -gy.at<float>(r, c), nz = 1.0;
      const double shade = std::clamp((nx * sx + ny * sy + nz * sz) / std::sqrt(nx * nx + ny * ny + nz * nz), 0.0, 1.0);
      const double k = 0.35 + 0.65 * shade;
      for (int ch = 0; ch < 3; ++ch) px[ch] = static_cast<uint8_t>(std::clamp(px[ch] * k, 0.0, 255.0));
    }
  }
  // Lower margin: scale bar and colour key.
  const int margin = 40;
  cv::Mat out(dem.rows + margin, std::max(dem.cols, 320), CV_8UC3, cv::Scalar(255, 255, 255));
  colour.copyTo(out(cv::Rect(0, 0, dem.cols, dem.rows)));
  cv::Mat bar = out(cv::Rect(0, dem.rows, out.cols, margin));
  drawScaleBar(bar, dem.cell_m);
  const int kx = out.cols - 170, ky = dem.rows + 8;
  for (int i = 0; i < 100; ++i) {
    cv::Mat one(1, 1, CV_8U, cv::Scalar(static_cast<int>(i * 255 / 99))), c3;
    cv::applyColorMap(one, c3, cv::COLORMAP_TURBO);
    const cv::Vec3b v = c3.at<cv::Vec3b>(0, 0);
    cv::line(out, cv::Point(kx + i, ky), cv::Point(kx + i, ky + 10), cv::Scalar(v[0], v[1], v[2]));
  }
  char text[64];
  std::snprintf(text, sizeof text, "%.2f .. %.2f m", lo, hi);
  cv::putText(out, text, cv::Point(kx, ky + 26), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  return out;
}

cv::Mat orthoPreview(const cv::Mat& ortho, const cv::Mat& valid, double cell_m) {
  cv::Mat grey = ortho.clone();
  if (!valid.empty()) grey.setTo(255, valid == 0);
  cv::Mat out;
  cv::cvtColor(grey, out, cv::COLOR_GRAY2BGR);
  drawScaleBar(out, cell_m);
  return out;
}

cv::Mat tieOverlay(const cv::Mat& grey, const std::vector<Vec2>& pixels, const std::vector<bool>& inter) {
  cv::Mat out;
  cv::cvtColor(grey, out, cv::COLOR_GRAY2BGR);
  const int arm = std::max(3, grey.cols / 170);
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    const cv::Point p(static_cast<int>(std::lround(pixels[i].x())), static_cast<int>(std::lround(pixels[i].y())));
    const cv::Scalar colour = (i < inter.size() && inter[i]) ? cv::Scalar(0, 0, 255) : cv::Scalar(255, 0, 0);
    cv::line(out, p - cv::Point(arm, 0), p + cv::Point(arm, 0), colour, 1);
    cv::line(out, p - cv::Point(0, arm), p + cv::Point(0, arm), colour, 1);
  }
  return out;
}

}  // namespace areomap::products
