// report.html: one self-contained page an operator opens after a pass: summary figures,
// the paper's precision methods 1-3 before and after the adjustment, a residual histogram and per-image
// residuals (inline SVG), DEM and ortho previews with scale, tie-point overlays, stage timings and
// warnings. No external resource: images are embedded as data: URIs, plots are inline SVG, no scripts.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "ground/adjust/AdjustProducts.hpp"

namespace areomap::products {

struct HtmlImage {
  std::string caption;
  cv::Mat image;  // 8-bit grey or BGR; embedded as PNG (downscaled to at most max_px wide)
};

struct HtmlInputs {
  std::string site;
  const ground::AdjustReport* report = nullptr;  // optional
  std::vector<std::pair<std::string, std::string>> summary;  // label, value
  std::vector<double> residuals_px;                          // per observation (histogram)
  std::vector<std::pair<std::string, double>> image_rms_px;  // per image (bars)
  std::vector<HtmlImage> products;  // DEM, ortho previews
  std::vector<HtmlImage> overlays;  // tie points per image
  std::vector<std::string> warnings;
};

std::string base64(const std::vector<unsigned char>& bytes);
// The page as text; write it with cli::writeFileAtomic.
std::string reportHtml(const HtmlInputs& in, int max_px = 900);
std::string htmlEscape(const std::string& text);

}  // namespace areomap::products
