// The seen classes (ground/dem/DemSeen.hpp) made again on a products folder's DEM, against truth, without
// the products pass: reclassify_check DATASET PRODUCTS (products made with the true models, e.g.
// products_bench --truth-models). PRODUCTS' dem.tif, dem_sigma.tif and dem_seen.tif (its measured cells)
// are classified again by this build's classifyDemCells; prints the truth figures (TruthSeen.hpp, no ortho)
// before and after, the DEM's error over the measured cells it empties per truth class, and the RMSE over
// the filled cells. The kriged cells the pass emptied are not in dem.tif: they stay empty.
#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/DemRaster.hpp"
#include "ground/dem/DemSeen.hpp"
#include "ground/ortho/Orthoimage.hpp"
#include "ground/products/TruthSeen.hpp"
#include <algorithm>
#include <cmath>
#include "ground/raster/RasterFiles.hpp"
#include "tests/ground/products/TruthDatum.hpp"

using namespace areomap;

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
  return 0;
}
