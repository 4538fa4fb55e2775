#include "ground/products/TruthSeen.hpp"

#include <algorithm>
#include <cmath>

#include "ground/cli/Parallel.hpp"
#include "ground/dem/DemSeen.hpp"
#include "ground/dem/Viewshed.hpp"
#include "ground/ortho/Orthoimage.hpp"

namespace areomap::products {

namespace {

constexpr double kTruthToleranceM = 0.001;  // the true surface is exact: only rounding
constexpr int kGreyTolerance = 2;            // rounding of two bilinear samples

// The true DEM at the cell centres of `grid` (bilinear; nodata where it has no value).
DemGrid sampled(const DemGrid& truth, const DemGrid& grid) {
  DemGrid s = grid;
  s.nodata = truth.nodata;
  s.values.assign(static_cast<std::size_t>(grid.cols) * grid.rows, s.nodata);
  for (int r = 0; r < grid.rows; ++r) {
    for (int c = 0; c < grid.cols; ++c) {
      double t = 0.0;
      if (ortho::demElevation(truth, grid.northOfRow(r), grid.eastOfCol(c), t)) s.at(c, r) = static_cast<float>(t);
    }
  }
  return s;
}

// Whether `value` lies within the values of `truth` at (r, c) and its eight neighbours (filled ones).
bool agrees(const cv::Mat& truth, int r, int c, int value) {
  int lo = 256, hi = -1;
  for (int dr = -1; dr <= 1; ++dr) {
    for (int dc = -1; dc <= 1; ++dc) {
      const int rr = r + dr, cc = c + dc;
      if (rr < 0 || cc < 0 || rr >= truth.rows || cc >= truth.cols) continue;
      const int t = truth.at<uint8_t>(rr, cc);
      if (t == 0) continue;
      lo = std::min(lo, t);
      hi = std::max(hi, t);
    }
  }
  return value >= lo - kGreyTolerance && value <= hi + kGreyTolerance;
}

}  // namespace

std::vector<uint8_t> cellsSeen(const DemGrid& surface, const std::vector<cv::Mat>& images,
                               const std::vector<CameraModel>& models, double tolerance_m) {
  std::vector<uint8_t> seen(surface.values.size(), 0);
  std::vector<float> horizon;
  for (std::size_t k = 0; k < models.size() && k < images.size(); ++k) {
    if (images[k].empty()) continue;
    const CameraModel& m = models[k];
    dem::horizonFrom(surface, m.c, horizon, false);
    const dem::ImageCone cone = dem::imageCone(m);
    cli::parallelFor(static_cast<std::size_t>(surface.rows), 0, [&](std::size_t row) {
      const int r = static_cast<int>(row);
      for (int c = 0; c < surface.cols; ++c) {
        const std::size_t i = row * surface.cols + c;
        const float z = surface.values[i];
        if (seen[i] || z == surface.nodata || z + tolerance_m < horizon[i]) continue;
        seen[i] = dem::imageSees(m, cone, Vec3(surface.northOfRow(r), surface.eastOfCol(c), -z));
      }
    });
  }
  return seen;
}

SeenTruth seenAgainstTruth(const DemGrid& dem, const cv::Mat* ortho_image, const DemGrid& truth_dem,
                           const std::vector<cv::Mat>& images, const std::vector<CameraModel>& truth_models,
                           const Vec3& g, double max_range_m, const std::vector<uint8_t>* classes) {
  SeenTruth out;
  const DemGrid truth = sampled(truth_dem, dem);
  const std::vector<uint8_t> seen = cellsSeen(truth, images, truth_models, kTruthToleranceM);
  cv::Mat truth_ortho;
  if (ortho_image != nullptr && ortho_image->rows == dem.rows && ortho_image->cols == dem.cols) {
    std::vector<ortho::OrthoSource> sources;
    for (std::size_t k = 0; k < truth_models.size() && k < images.size(); ++k)
      sources.push_back(ortho::OrthoSource{images[k], truth_models[k]});
    truth_ortho = ortho::makeOrthoimage(truth, sources, ortho::OrthoOptions{}).image;
  }
  long long empty = 0, filled = 0, agree = 0;
  for (int r = 0; r < dem.rows; ++r) {
    for (int c = 0; c < dem.cols; ++c) {
      const std::size_t i = static_cast<std::size_t>(r) * dem.cols + c;
      if (truth.values[i] == truth.nodata) continue;
      if (std::hypot(dem.northOfRow(r) - g.x(), dem.eastOfCol(c) - g.y()) > max_range_m) continue;
      const bool has = dem.values[i] != dem.nodata && std::isfinite(dem.values[i]);
      if (!seen[i]) {
        ++out.cells_unseen;
        empty += !has;
        out.unseen_measured += classes != nullptr && i < classes->size() && (*classes)[i] == dem::kCellMeasured;
        continue;
      }
      ++out.cells_seen;
      filled += has;
      if (truth_ortho.empty()) continue;
      const int v = ortho_image->at<uint8_t>(r, c), t = truth_ortho.at<uint8_t>(r, c);
      if (v == 0 || t == 0) continue;
      ++out.cells_compared;
      agree += agrees(truth_ortho, r, c, v);
    }
  }
  const auto fraction = [](long long part, long long whole) {
    return whole > 0 ? std::optional<double>(static_cast<double>(part) / static_cast<double>(whole)) : std::nullopt;
  };
  out.unseen_empty = fraction(empty, out.cells_unseen);
  out.seen_filled = fraction(filled, out.cells_seen);
  out.ortho_agreement = fraction(agree, out.cells_compared);
  return out;
}

}  // namespace areomap::products
