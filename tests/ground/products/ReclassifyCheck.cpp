// The seen classes (ground/dem/DemSeen.hpp) made again on a products folder's DEM, against truth, without
// the products pass: reclassify_check DATASET PRODUCTS (products made with the true models, e.g.
// products_bench --truth-models). PRODUCTS' dem.tif, dem_sigma.tif and dem_seen.tif (its measured cells)
// are classified again by this build's classifyDemCells; prints the truth figures (TruthSeen.hpp, no ortho)
// before and after, the DEM's error over the measured cells it empties per truth class, and the RMSE over
// the filled cells. The kriged cells the pass emptied are not in dem.tif: they stay empty.
// Then per range band the truth-unseen cells left filled (measured, interpolated) and the truth-seen cells
// left empty, before and after. Of the cells holding no point at 10-20 and 20-40 m (truth-unseen ones kept,
// truth-seen ones kept, truth-seen ones emptied): with RECLASSIFY_GAPS set, histograms of their radial gaps
// (reclassifyGapRows) and of how far inside the images their projection lies; with RECLASSIFY_CLEARANCE,
// of how far their estimate clears the measured cells' horizon in sigmas. For dem.tif to hold every kriged
// cell, make PRODUCTS with a build whose products pass classifies without emptying.
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

// What the histograms read: the DEM as kriged (elevation, sigma) and its measured cells, the true cameras,
// the truth classes and the classes made, the gimbal centre.
struct ReclassifyInputs {
  const DemGrid &z0, &sigma0;
  const std::vector<uint8_t>& measured;
  const std::vector<CameraModel>& models;
  const std::vector<uint8_t>&truth, &classes;
  Vec3 centre;
};

const char* const kReclassifyKinds[3] = {"unseen kept", "seen kept", "seen emptied"};

// Of the kriged cells holding no point at 10-40 m: 2 x kind (0 truth-unseen kept interpolated, 1 truth-seen
// kept, 2 truth-seen emptied) + 1 beyond 20 m; -1 for the others.
int reclassifyKind(const ReclassifyInputs& in, int col, int row) {
  const std::size_t i = static_cast<std::size_t>(row) * in.z0.cols + col;
  if (in.measured[i] || in.z0.values[i] == in.z0.nodata || in.truth[i] == products::kTruthMarginal) return -1;
  const bool kept = in.classes[i] == dem::kCellInterpolated;
  if (in.truth[i] != products::kTruthSeen && !kept) return -1;
  const double range = std::hypot(in.z0.northOfRow(row) - in.centre.x(), in.z0.eastOfCol(col) - in.centre.y());
  if (range < 10 || range >= 40) return -1;
  const int kind = in.truth[i] != products::kTruthSeen ? 0 : kept ? 1 : 2;
  return 2 * kind + (range >= 20);
}

// One histogram per kind and band: "label, truth KIND, BAND m: <UPPER:COUNT ...", the last "<-1" the rest.
template <int N>
void reclassifyPrint(const char* label, const long long (&tally)[6][N], const double (&upper)[N]) {
  for (int k = 0; k < 6; ++k) {
    std::printf("%s, truth %s, %s m:", label, kReclassifyKinds[k / 2], k % 2 ? "20-40" : "10-20");
    for (int h = 0; h < N; ++h) std::printf(" <%g:%lld", upper[h] > 1e100 ? -1 : upper[h], tally[k][h]);
    std::printf("\n");
  }
}

// The radial gaps (reclassifyGapRows, the fewest rows over the cameras whose images hold the cell) and how
// far inside those images the cells' projections lie (pixels from the border, the most over them).
void reclassifyGaps(const ReclassifyInputs& in) {
  constexpr int kHist = 13, kBorders = 6;
  constexpr double kUpper[kHist] = {0.5, 1, 1.5, 2, 3, 4, 6, 8, 12, 16, 24, 1e9, 2e300};
  constexpr double kInside[kBorders] = {4, 8, 16, 32, 64, 1e9};
  long long hist[6][kHist] = {}, inside_hist[6][kBorders] = {};
  std::vector<dem::ImageCone> cones;
  for (const CameraModel& m : in.models) cones.push_back(dem::imageCone(m));
  const DemGrid& z0 = in.z0;
  for (int r = 0; r < z0.rows; ++r)
    for (int c = 0; c < z0.cols; ++c) {
      const int kind = reclassifyKind(in, c, r);
      if (kind < 0) continue;
      const Vec3 x(z0.northOfRow(r), z0.eastOfCol(c), -z0.at(c, r));
      double best = 3e300, inside = -1;
      for (std::size_t k = 0; k < in.models.size(); ++k) {
        const CameraModel& m = in.models[k];
        Vec2 px;
        if (!dem::imageSees(m, cones[k], x) || project(m, x, px) != Status::kOk) continue;
        inside = std::max(inside, std::min({px.x() + 0.5, px.y() + 0.5, m.width - 0.5 - px.x(), m.height - 0.5 - px.y()}));
        const double g = reclassifyGapRows(z0, in.measured, m, cones[k].px_per_rad, c, r, 48.0);
        if (g >= 0) best = std::min(best, g);
      }
      int h = 0, o = 0;
      while (h + 1 < kHist && best >= kUpper[h]) ++h;
      while (o + 1 < kBorders && inside >= kInside[o]) ++o;
      ++hist[kind][h];
      ++inside_hist[kind][o];
    }
  reclassifyPrint("gap rows", hist, kUpper);
  reclassifyPrint("px inside", inside_hist, kInside);
}

// How far the cells' kriged estimates clear the horizon of the measured cells alone (dem::horizonFrom over
// a grid of them, the rest nodata), over the estimate's sigma, the most over the cameras whose images hold
// the cell.
void reclassifyClearance(const ReclassifyInputs& in) {
  const DemGrid& z0 = in.z0;
  DemGrid only = z0;
  for (std::size_t i = 0; i < only.values.size(); ++i)
    if (!in.measured[i]) only.values[i] = only.nodata;
  std::vector<float> clear(z0.values.size(), -std::numeric_limits<float>::infinity()), horizon;
  for (const CameraModel& m : in.models) {
    const dem::ImageCone cone = dem::imageCone(m);
    dem::horizonFrom(only, m.c, horizon, false);
    for (int r = 0; r < z0.rows; ++r)
      for (int c = 0; c < z0.cols; ++c) {
        const std::size_t i = static_cast<std::size_t>(r) * z0.cols + c;
        if (reclassifyKind(in, c, r) < 0 || !dem::imageSees(m, cone, Vec3(z0.northOfRow(r), z0.eastOfCol(c), -z0.values[i]))) continue;
        const float sv = in.sigma0.values[i];
        const double sigma = sv == in.sigma0.nodata ? 1e-3 : std::max(1e-3, static_cast<double>(sv));
        clear[i] = std::max(clear[i], static_cast<float>((z0.values[i] - horizon[i]) / sigma));
      }
  }
  constexpr int kClear = 10;
  constexpr double kClearUpper[kClear] = {-3, -2, -1, -0.5, 0, 0.5, 1, 2, 3, 1e300};
  long long tally[6][kClear] = {};
  for (int r = 0; r < z0.rows; ++r)
    for (int c = 0; c < z0.cols; ++c) {
      const int kind = reclassifyKind(in, c, r);
      if (kind < 0) continue;
      int h = 0;
      while (h + 1 < kClear && clear[static_cast<std::size_t>(r) * z0.cols + c] >= kClearUpper[h]) ++h;
      ++tally[kind][h];
    }
  reclassifyPrint("clearance sigmas", tally, kClearUpper);
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
  const DemGrid z0 = kr.elevation, sigma0 = kr.sigma;
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
  const ReclassifyInputs in{z0, sigma0, measured, models, b.seen, s.classes, datum.centre};
  if (std::getenv("RECLASSIFY_GAPS") != nullptr) reclassifyGaps(in);
  if (std::getenv("RECLASSIFY_CLEARANCE") != nullptr) reclassifyClearance(in);
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
