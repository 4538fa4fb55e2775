#include "ground/products/ReportHtml.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ground/cli/Parallel.hpp"

namespace areomap::products {

namespace {

std::string fmt(double v, int digits = 3) {
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", digits, v);
  return b;
}

std::string dataUri(const cv::Mat& image, int max_px) {
  cv::Mat img = image;
  if (img.cols > max_px) {
    const double s = static_cast<double>(max_px) / img.cols;
    cv::resize(image, img, cv::Size(), s, s, cv::INTER_AREA);
  }
  std::vector<unsigned char> png;
  cv::imencode(".png", img, png);
  return "data:image/png;base64," + base64(png);
}

// Histogram of values as an inline SVG bar chart.
std::string histogramSvg(const std::vector<double>& values, const std::string& xlabel) {
  const int w = 560, h = 220, left = 50, bottom = 40, bins = 30;
  double hi = 0;
  for (double v : values) hi = std::max(hi, v);
  if (!(hi > 0)) hi = 1;
  std::vector<int> count(bins, 0);
  for (double v : values) count[std::min(bins - 1, static_cast<int>(v / hi * bins))]++;
  const int top = std::max(1, *std::max_element(count.begin(), count.end()));
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << w << "' height='" << h << "' role='img'>";
  s << "<rect width='100%' height='100%' fill='#fff'/>";
  const double bw = static_cast<double>(w - left - 10) / bins;
  for (int i = 0; i < bins; ++i) {
    const double bh = (h - bottom - 10) * count[i] / static_cast<double>(top);
    s << "<rect x='" << fmt(left + i * bw, 1) << "' y='" << fmt(h - bottom - bh, 1) << "' width='" << fmt(bw - 1, 1)
      << "' height='" << fmt(bh, 1) << "' fill='#3b6ea5'/>";
  }
  s << "<line x1='" << left << "' y1='" << h - bottom << "' x2='" << w - 10 << "' y2='" << h - bottom
    << "' stroke='#000'/>";
  s << "<text x='" << left << "' y='" << h - bottom + 16 << "' font-size='12'>0</text>";
  s << "<text x='" << w - 60 << "' y='" << h - bottom + 16 << "' font-size='12'>" << fmt(hi, 2) << "</text>";
  s << "<text x='" << (w / 2 - 40) << "' y='" << h - 6 << "' font-size='12'>" << htmlEscape(xlabel) << "</text>";
  s << "<text x='4' y='16' font-size='12'>max " << top << "</text>";
  s << "</svg>";
  return s.str();
}

std::string barsSvg(const std::vector<std::pair<std::string, double>>& bars, const std::string& unit) {
  const int row = 16, w = 560, label_w = 120;
  const int h = std::max(1, static_cast<int>(bars.size())) * row + 24;
  double hi = 0;
  for (const auto& b : bars) hi = std::max(hi, b.second);
  if (!(hi > 0)) hi = 1;
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << w << "' height='" << h << "' role='img'>";
  s << "<rect width='100%' height='100%' fill='#fff'/>";
  for (std::size_t i = 0; i < bars.size(); ++i) {
    const double len = (w - label_w - 80) * bars[i].second / hi;
    const int y = static_cast<int>(i) * row + 4;
    s << "<text x='2' y='" << y + 11 << "' font-size='11'>" << htmlEscape(bars[i].first) << "</text>";
    s << "<rect x='" << label_w << "' y='" << y << "' width='" << fmt(len, 1) << "' height='" << row - 4
      << "' fill='#c0504d'/>";
    s << "<text x='" << fmt(label_w + len + 4, 1) << "' y='" << y + 11 << "' font-size='11'>"
      << fmt(bars[i].second, 3) << ' ' << htmlEscape(unit) << "</text>";
  }
  s << "</svg>";
  return s.str();
}

std::string precisionRow(const std::string& name, const ImageDifferences& b, const ImageDifferences& a,
                         const char* unit) {
  std::ostringstream s;
  s << "<tr><td>" << name << " (" << unit << ")</td><td>" << fmt(b.x) << " / " << fmt(b.y) << " / " << fmt(b.dist)
    << "</td><td>" << fmt(a.x) << " / " << fmt(a.y) << " / " << fmt(a.dist) << "</td><td>" << a.count
    << "</td></tr>";
  return s.str();
}

}  // namespace

std::string base64(const std::vector<unsigned char>& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = (bytes[i] << 16) | (bytes[i + 1] << 8) | bytes[i + 2];
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += k[(v >> 6) & 63];
    out += k[v & 63];
  }
  if (i < bytes.size()) {
    const unsigned v = (bytes[i] << 16) | (i + 1 < bytes.size() ? bytes[i + 1] << 8 : 0);
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? k[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string htmlEscape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '&': out += "&amp;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string reportHtml(const HtmlInputs& in, int max_px) {
  // The images' data URIs (scaling and PNG encoding: most of the page's time) made on threads first, each
  // placed in its figure below: the same page for any thread count.
  const std::size_t n_products = in.products.size();
  std::vector<std::string> uris(n_products + in.overlays.size());
  cli::parallelFor(uris.size(), 0, [&](std::size_t k) {
    const bool product = k < n_products;
    const HtmlImage& im = product ? in.products[k] : in.overlays[k - n_products];
    if (!im.image.empty()) uris[k] = dataUri(im.image, product ? max_px : 300);
  });
  std::ostringstream s;
  s << "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'><title>areomap report: "
    << htmlEscape(in.site) << "</title>\n<style>body{font-family:sans-serif;margin:24px;background:#fafafa;color:#222}"
       "table{border-collapse:collapse;margin:8px 0}td,th{border:1px solid #bbb;padding:3px 8px;text-align:left}"
       "th{background:#e8e8e8}h2{border-bottom:2px solid #3b6ea5;padding-bottom:2px}"
       "figure{display:inline-block;margin:6px;vertical-align:top}figcaption{font-size:12px}"
       ".warn{color:#a00}img{border:1px solid #999;max-width:100%}</style></head><body>\n";
  s << "<h1 id='title'>areomap ground products: " << htmlEscape(in.site) << "</h1>\n";
  s << "<h2>Summary</h2><table>";
  for (const auto& kv : in.summary) {
    s << "<tr><th>" << htmlEscape(kv.first) << "</th><td>" << htmlEscape(kv.second) << "</td></tr>";
  }
  s << "</table>\n";
  const ground::AdjustReport* r = in.report;
  if (r != nullptr) {
    s << "<h2>Precision (paper §3.5), before / after adjustment</h2><table><tr><th>measure (x / y / dist)</th>"
         "<th>before</th><th>after</th><th>count</th></tr>";
    s << precisionRow("method 1: back-projection residuals", r->method1_before, r->method1_after, "px");
    s << "<tr><td>method 2: 3-D differences of inter-stereo ties (m), x / y / z</td><td>"
      << fmt(r->method2_before.x) << " / " << fmt(r->method2_before.y) << " / " << fmt(r->method2_before.z)
      << "</td><td>" << fmt(r->method2_after.x) << " / " << fmt(r->method2_after.y) << " / "
      << fmt(r->method2_after.z) << "</td><td>" << r->method2_after.count << "</td></tr>";
    s << precisionRow("method 3: 2-D differences after transfer", r->method3_before, r->method3_after, "px");
    s << "</table><p>RMS residual " << fmt(r->rms_px) << " px, sigma0 " << fmt(r->sigma0) << ", "
      << r->iterations << " iterations; tie points: " << r->tie_points.intra << " intra-stereo, "
      << r->tie_points.inter << " inter-stereo, " << r->tie_points.rejected << " rejected.</p>\n";
    if (r->truth) {
      s << "<p>Against truth (common datum rotation removed; raw in brackets): EO " << fmt(r->truth->eo_px)
        << " px (" << fmt(r->truth->eo_px_raw) << ")";
      if (r->truth->ground_m) s << ", ground " << fmt(*r->truth->ground_m, 4) << " m";
      if (r->truth->ground_m_raw) s << " (" << fmt(*r->truth->ground_m_raw, 4) << ")";
      if (r->truth->dem_rmse_m) s << ", DEM RMSE " << fmt(*r->truth->dem_rmse_m, 4) << " m";
      s << ".</p>\n";
    }
  }
  s << "<h2>Residuals</h2>";
  if (in.residuals_px.empty()) {
    s << "<p>No residuals available.</p>";
  } else {
    s << "<figure>" << histogramSvg(in.residuals_px, "back-projection residual |v| (px)")
      << "<figcaption>Histogram of the residuals of " << in.residuals_px.size() << " observations</figcaption></figure>";
  }
  if (!in.image_rms_px.empty()) {
    s << "<figure>" << barsSvg(in.image_rms_px, "px") << "<figcaption>RMS residual per image</figcaption></figure>";
  }
  s << "\n<h2>Products</h2>";
  if (in.products.empty()) s << "<p class='warn'>No DEM or orthoimage was made (see warnings).</p>";
  for (std::size_t k = 0; k < n_products; ++k) {
    const HtmlImage& im = in.products[k];
    if (im.image.empty()) continue;
    s << "<figure><img alt='" << htmlEscape(im.caption) << "' src='" << uris[k] << "'><figcaption>"
      << htmlEscape(im.caption) << "</figcaption></figure>\n";
  }
  s << "<h2>Tie points</h2><p>Blue: intra-stereo, red: inter-stereo.</p>";
  for (std::size_t k = 0; k < in.overlays.size(); ++k) {
    const HtmlImage& im = in.overlays[k];
    if (im.image.empty()) continue;
    s << "<figure><img alt='" << htmlEscape(im.caption) << "' src='" << uris[n_products + k]
      << "'><figcaption>" << htmlEscape(im.caption) << "</figcaption></figure>\n";
  }
  if (r != nullptr && !r->seconds.empty()) {
    s << "<h2>Stage timings</h2><table><tr><th>stage</th><th>seconds</th></tr>";
    for (const auto& kv : r->seconds) s << "<tr><td>" << htmlEscape(kv.first) << "</td><td>" << fmt(kv.second, 2) << "</td></tr>";
    s << "</table>";
  }
  s << "<h2>Warnings</h2>";
  if (in.warnings.empty()) s << "<p>None.</p>";
  else {
    s << "<ul>";
    for (const std::string& w : in.warnings) s << "<li class='warn'>" << htmlEscape(w) << "</li>";
    s << "</ul>";
  }
  s << "\n</body></html>\n";
  return s.str();
}

}  // namespace areomap::products
