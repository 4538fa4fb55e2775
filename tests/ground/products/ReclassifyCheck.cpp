// The seen classes (ground/dem/DemSeen.hpp) made again on a products folder's DEM, against truth, without
// the products pass: reclassify_check DATASET PRODUCTS (products made with the true models, e.g.
// products_bench --truth-models). PRODUCTS' dem.tif, dem_sigma.tif and dem_seen.tif (its measured cells)
// are classified again by this build's classifyDemCells; prints the truth figures (TruthSeen.hpp, no ortho)
// before and after, the DEM's error over the measured cells it empties per truth class, and the RMSE over
// the filled cells. The kriged cells the pass emptied are not in dem.tif: they stay empty.
// Then per range band the truth-unseen cells left filled (measured, interpolated) and the truth-seen cells
// left empty, before and after; with RECLASSIFY_GAPS set, histograms of the radial gaps (reclassifyGapRows)
// of the interpolated cells the classes keep, per truth class. For dem.tif to hold every kriged cell, make
// PRODUCTS with a build whose products pass classifies without emptying.
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/DemRaster.hpp"
#include "ground/dem/DemSeen.hpp"
#include "ground/dem/Viewshed.hpp"
#include "ground/ortho/Orthoimage.hpp"
#include "ground/products/TruthSeen.hpp"
#include <algorithm>
#include <cmath>
#include <limits>
#include "ground/raster/RasterFiles.hpp"
#include "tests/ground/products/TruthDatum.hpp"

using namespace areomap;

namespace {

// Along the horizontal line from `camera`'s centre through the centre of cell (col, row) of `z`, the gap
// between the nearest measured cells before and beyond it (metres), over the ground's spacing of one image
// row there (the line of sight's distance times a pixel's angle over the tangent of its grazing angle):
// how many rows of that camera's image the gap spans. +infinity where no measured cell lies on one side
// within `max_rows` rows, -1 where the cell is empty or lies straight below the camera.
double reclassifyGapRows(const DemGrid& z, const std::vector<uint8_t>& measured, const CameraModel& camera,
                         double px_per_rad, int col, int row, double max_rows) {
  const std::size_t i = static_cast<std::size_t>(row) * z.cols + col;
  if (z.values[i] == z.nodata || !std::isfinite(z.values[i])) return -1.0;
  const double n = z.northOfRow(row), e = z.eastOfCol(col);
  const Vec3 to = Vec3(n, e, -z.values[i]) - camera.c;
  const double horizontal = std::hypot(to.x(), to.y()), dist = to.norm();
  if (!(horizontal > 0.0) || !(px_per_rad > 0.0)) return -1.0;
  const double pixel_rad = 1.0 / px_per_rad;
  const double row_m = dist * pixel_rad / std::max(to.z() / horizontal, pixel_rad);
  const double un = to.x() / horizontal, ue = to.y() / horizontal, half = 0.5 * z.cell_m;
  const int steps = std::min(4096, static_cast<int>(std::ceil((max_rows * row_m + z.cell_m) / half)));
  double side[2] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  for (int s = 0; s < 2; ++s) {
    for (int k = 1; k <= steps; ++k) {
      const double t = (s == 0 ? -1.0 : 1.0) * k * half;
      if (s == 0 && k * half >= horizontal) break;  // reached the camera
      const int c = static_cast<int>(std::floor((e + t * ue - z.east0_m) / z.cell_m));
      const int r = static_cast<int>(std::floor((z.north0_m - (n + t * un)) / z.cell_m));
      if (c == col && r == row) continue;
      if (c < 0 || r < 0 || c >= z.cols || r >= z.rows) break;
      if (measured[static_cast<std::size_t>(r) * z.cols + c]) {
        side[s] = k * half;
        break;
      }
    }
  }
  return (side[0] + side[1]) / row_m;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) return 2;
  const std::string root = argv[1], out = argv[2];
  const Dataset ds = readDataset(root);
  const DemGrid truth = readDemGeoTiff(root + "/truth/dem.tif");
  dem::KrigingResult kr;
  kr.elevation = readDemGeoTiff(out + "/dem.tif");
  kr.sigma = readDemGeoTiff(out + "/dem_sigma.tif");
  const raster::Float32Raster cls = raster::readGeoTiff(out + "/dem_seen.tif");
  const test::TruthDatum datum = test::truthDatum(ds, root, out);
  std::vector<cv::Mat> images;
  for (const Pair& p : ds.pairs)
    for (const ImageRef* ref : {&p.left, p.right ? &*p.right : nullptr})
      if (ref != nullptr) images.push_back(cv::imread(ref->image_path, cv::IMREAD_GRAYSCALE));
  std::vector<CameraModel> models = datum.truth_models;
  for (std::size_t k = 0; k < models.size(); ++k) {
    models[k].width = images[k].cols;
    models[k].height = images[k].rows;
  }
  std::vector<uint8_t> measured(kr.elevation.values.size(), 0), before(measured.size(), 0);
  for (std::size_t i = 0; i < measured.size(); ++i) {
    before[i] = static_cast<uint8_t>(cls.values[i]);
    measured[i] = before[i] == dem::kCellMeasured;
  }
  products::TruthFrame frame;
  frame.gimbal = datum.centre;
  frame.r = datum.rotation;
  const products::SeenTruth b = products::seenAgainstTruth(kr.elevation, nullptr, truth, images, models, frame, 60.0, &before);
  std::printf("before: unseen %lld, %.2f %% empty (%lld measured); seen %lld, %.2f %% filled\n", b.cells_unseen,
              100 * b.unseen_empty.value_or(-1), b.unseen_measured, b.cells_seen, 100 * b.seen_filled.value_or(-1));
  const DemGrid z0 = kr.elevation;
  const dem::DemSeen s = dem::classifyDemCells(kr, measured, models);
  {
    std::vector<double> err[3], all;
    for (int r = 0; r < z0.rows; ++r)
      for (int c = 0; c < z0.cols; ++c) {
        const std::size_t i = static_cast<std::size_t>(r) * z0.cols + c;
        if (!measured[i]) continue;
        double t = 0;
        if (!ortho::demElevation(truth, z0.northOfRow(r), z0.eastOfCol(c), t)) continue;
        const double e = std::fabs(z0.values[i] - t);
        if (s.classes[i] == dem::kCellUnseen) err[b.seen[i]].push_back(e);
        else if (i % 7 == 0) all.push_back(e);
      }
    auto med = [](std::vector<double> v, double q) { if (v.empty()) return -1.0; std::sort(v.begin(), v.end()); return v[static_cast<std::size_t>(q * (v.size() - 1))]; };
    for (int k = 0; k < 3; ++k) std::printf("hidden, truth class %d: %zu cells, |dz| median %.3f p90 %.3f\n", k, err[k].size(), med(err[k], 0.5), med(err[k], 0.9));
    std::printf("kept measured (1/7): |dz| median %.3f p90 %.3f\n", med(all, 0.5), med(all, 0.9));
  }
  if (std::getenv("RECLASSIFY_GAPS") != nullptr) {
    // The radial gaps (reclassifyGapRows, the fewest rows over the cameras holding the cell) of the
    // interpolated cells the classes keep filled, per truth class, at 10-20 and 20-40 m.
    constexpr int kHist = 13;
    constexpr double kUpper[kHist] = {0.5, 1, 1.5, 2, 3, 4, 6, 8, 12, 16, 24, 1e9, 2e300};
    long long hist[2][2][kHist] = {};
    std::vector<dem::ImageCone> cones;
    for (const CameraModel& m : models) cones.push_back(dem::imageCone(m));
    for (int r = 0; r < z0.rows; ++r)
      for (int c = 0; c < z0.cols; ++c) {
        const std::size_t i = static_cast<std::size_t>(r) * z0.cols + c;
        if (s.classes[i] != dem::kCellInterpolated || b.seen[i] == products::kTruthMarginal) continue;
        const double range = std::hypot(z0.northOfRow(r) - datum.centre.x(), z0.eastOfCol(c) - datum.centre.y());
        if (range < 10 || range >= 40) continue;
        const Vec3 x(z0.northOfRow(r), z0.eastOfCol(c), -z0.values[i]);
        double best = 3e300;
        for (std::size_t k = 0; k < models.size(); ++k) {
          if (!dem::imageSees(models[k], cones[k], x)) continue;
          const double g = reclassifyGapRows(z0, measured, models[k], cones[k].px_per_rad, c, r, 48.0);
          if (g >= 0) best = std::min(best, g);
        }
        int h = 0;
        while (h + 1 < kHist && best >= kUpper[h]) ++h;
        ++hist[b.seen[i] == products::kTruthSeen][range >= 20][h];
      }
    for (int t = 0; t < 2; ++t)
      for (int band = 0; band < 2; ++band) {
        std::printf("gap rows, truth %s, %s m:", t ? "seen" : "unseen", band ? "20-40" : "10-20");
        for (int h = 0; h < kHist; ++h) std::printf(" <%g:%lld", kUpper[h] > 1e100 ? -1 : kUpper[h], hist[t][band][h]);
        std::printf("\n");
      }
  }
  std::printf("classes: %lld measured, %lld interpolated, %lld emptied (%lld hidden)\n", s.measured, s.interpolated,
              s.emptied, s.hidden);
  const products::SeenTruth a = products::seenAgainstTruth(kr.elevation, nullptr, truth, images, models, frame, 60.0, &s.classes);
  auto rmse = [&](const DemGrid& g) {
    double s2 = 0; long long n = 0;
    for (int r = 0; r < g.rows; ++r)
      for (int c = 0; c < g.cols; ++c) {
        const float v = g.values[static_cast<std::size_t>(r) * g.cols + c];
        double t = 0;
        if (v == g.nodata || !std::isfinite(v) || !ortho::demElevation(truth, g.northOfRow(r), g.eastOfCol(c), t)) continue;
        s2 += (v - t) * (v - t); ++n;
      }
    return std::sqrt(s2 / std::max(1LL, n));
  };
  std::printf("RMSE over filled cells: before %.4f m, after %.4f m\n", rmse(z0), rmse(kr.elevation));
  std::printf("after: unseen %lld, %.2f %% empty (%lld measured); seen %lld, %.2f %% filled\n", a.cells_unseen,
              100 * a.unseen_empty.value_or(-1), a.unseen_measured, a.cells_seen, 100 * a.seen_filled.value_or(-1));
  // Per range band from the gimbal centre: the unseen cells left filled (measured, interpolated) and the
  // seen cells left empty, before and after.
  constexpr int kBands = 5;
  constexpr double kEdges[kBands + 1] = {0, 5, 10, 20, 40, 1e9};
  long long tally[kBands][6] = {};
  for (int r = 0; r < z0.rows; ++r)
    for (int c = 0; c < z0.cols; ++c) {
      const std::size_t i = static_cast<std::size_t>(r) * z0.cols + c;
      const double range = std::hypot(z0.northOfRow(r) - datum.centre.x(), z0.eastOfCol(c) - datum.centre.y());
      int band = 0;
      while (band + 1 < kBands && range >= kEdges[band + 1]) ++band;
      const bool was = z0.values[i] != z0.nodata && std::isfinite(z0.values[i]);
      const bool is = kr.elevation.values[i] != kr.elevation.nodata && std::isfinite(kr.elevation.values[i]);
      if (b.seen[i] == products::kTruthUnseen) {
        if (was) ++tally[band][measured[i] ? 0 : 1];
        if (is) ++tally[band][measured[i] ? 2 : 3];
      } else if (b.seen[i] == products::kTruthSeen) {
        tally[band][4] += !was;
        tally[band][5] += !is;
      }
    }
  std::printf("band     unseen filled before (meas, interp) after (meas, interp)   seen empty before after\n");
  for (int k = 0; k < kBands; ++k)
    std::printf("%4.0f-%-4.0f %10lld %10lld %10lld %10lld %12lld %10lld\n", kEdges[k], std::min(kEdges[k + 1], 999.0),
                tally[k][0], tally[k][1], tally[k][2], tally[k][3], tally[k][4], tally[k][5]);
  return 0;
}
