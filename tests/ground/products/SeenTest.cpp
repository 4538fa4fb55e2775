// Seen, interpolated, unseen (ground/dem/DemSeen.hpp, ground/products/TruthSeen.hpp) on a small rendered
// scene with rocks: the tiny preset's camera (256 px), four pairs, three times its rock density, the true
// models standing in for the adjusted ones.
//  - Against truth with the products tests' own ray cast (test::seenInTruth, the ray cast exactly against
//    the true terrain, sim::Terrain::castRay) on TruthSeen.hpp's definition (seen: the ground at the cell's
//    centre; unseen: every true node in the cell hidden by more than a pixel's angle; marginal cells left
//    out): per 5 m band, of the cells the true cameras do not see the fraction empty in dem.tif (report.json:
//    >= 95 %), of those they see the fraction filled (>= 95 % within 5 m, >= 68 % in all); report.json's
//    figures (their own horizon sweep in the true DEM) agree with the ray cast's within 2 points.
//  - dem_seen.tif: on dem.tif's grid, 0 exactly where dem.tif is empty, 2 where a point lies.
//  - The ortho never paints a cell from an image that the DEM itself hides it from (a ray marched through
//    dem.tif, products::terrainHides, with the same two-sigma tolerance).
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "ground/dataset/DemRaster.hpp"
#include "ground/dem/DemSeen.hpp"
#include "ground/dem/Viewshed.hpp"
#include "ground/ortho/Orthoimage.hpp"
#include "ground/products/DemCoverage.hpp"
#include "ground/products/Products.hpp"
#include "ground/raster/RasterFiles.hpp"
#include "tests/ground/products/SimScene.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

void rocky(sim::SimConfig& c) {
  c.rock_k = 0.24;  // three times the preset's: shadows behind many rocks
  test::seedFromEnvironment(c, "AREOMAP_SEEN_SEED");  // diagnostic knob
}

struct SeenRun {
  test::SimScene scene;
  sim::Terrain terrain;
  products::ProductsResult result;
  ground::AdjustReport report;
  std::string out;
  std::vector<double> px_per_rad;  // per image
};

const SeenRun& seenRun() {
  static const SeenRun run = [] {
    SeenRun r;
    sim::SimConfig config = sim::presetConfig("tiny");
    sim::setPairCount(config, 4);
    rocky(config);
    r.terrain = sim::Terrain::build(config);
    r.scene = test::makeSimScene("tiny", 4, &rocky);
    for (const products::ProductImage& im : r.scene.inputs.images) {
      r.scene.inputs.truth_models.push_back(im.model);
      r.px_per_rad.push_back(dem::imageCone(im.model).px_per_rad);
    }
    r.out = test::scratchDir("products_seen");
    r.report.truth = ground::TruthFigures{};
    products::ProductOptions options;
    options.dense_max_disparity_px = 64;
    options.max_range_m = 18.0;  // the tiny terrain ends at 20 m
    r.result = products::makeProducts(r.scene.inputs, options, r.out, &r.report);
    products::mergeIntoReport(r.result, r.report);
    return r;
  }();
  return run;
}

// TruthSeen.hpp's definition by the exact ray cast (products::kTruthSeen, kTruthMarginal, kTruthUnseen):
// the true ground at the centre of the cell (col, row) of `dem` is seen by some true camera (as
// test::seenInTerrain); else some node of the true surface within the cell (the nearest when none is),
// raised by one pixel's angle at its distance from the camera, is (marginal); else unseen.
int cellSeenByRayCast(const SeenRun& run, const DemGrid& truth, const DemGrid& dem, int col, int row) {
  const double half = 0.5 * dem.cell_m, n = dem.northOfRow(row), e = dem.eastOfCol(col);
  std::vector<std::pair<int, int>> nodes;
  const int r0 = static_cast<int>(std::ceil((truth.north0_m - n - half) / truth.cell_m - 0.5));
  const int r1 = static_cast<int>(std::ceil((truth.north0_m - n + half) / truth.cell_m - 0.5)) - 1;
  const int c0 = static_cast<int>(std::ceil((e - half - truth.east0_m) / truth.cell_m - 0.5));
  const int c1 = static_cast<int>(std::ceil((e + half - truth.east0_m) / truth.cell_m - 0.5)) - 1;
  for (int r = r0; r <= r1; ++r)
    for (int c = c0; c <= c1; ++c) nodes.emplace_back(c, r);
  if (nodes.empty())
    nodes.emplace_back(static_cast<int>(std::floor((e - truth.east0_m) / truth.cell_m)),
                       static_cast<int>(std::floor((truth.north0_m - n) / truth.cell_m)));
  double t = 0;
  if (ortho::demElevation(truth, n, e, t) && test::seenInTerrain(run.scene.inputs, run.terrain, Vec3(n, e, -t)))
    return products::kTruthSeen;
  for (const auto& [c, r] : nodes) {
    if (c < 0 || r < 0 || c >= truth.cols || r >= truth.rows || truth.at(c, r) == truth.nodata) continue;
    const Vec3 x(truth.northOfRow(r), truth.eastOfCol(c), -static_cast<double>(truth.at(c, r)));
    for (std::size_t k = 0; k < run.scene.inputs.images.size(); ++k) {
      const CameraModel& m = run.scene.inputs.images[k].model;
      const cv::Mat& grey = run.scene.inputs.images[k].grey;
      Vec2 px;
      if (project(m, x, px) != Status::kOk || px.x() < 0 || px.y() < 0 || px.x() > grey.cols - 1 || px.y() > grey.rows - 1)
        continue;
      const double tolerance = (x - m.c).norm() / run.px_per_rad[k];
      const Vec3 d = x - Vec3(0, 0, tolerance) - m.c;
      double hit = 0;
      if (run.terrain.castRay(m.c, d.normalized(), hit, d.norm() + 1.0) && hit >= d.norm() - 0.03)
        return products::kTruthMarginal;
    }
  }
  return products::kTruthUnseen;
}

}  // namespace

TEST_GROUP(SeenCells){};

TEST(SeenCells, UnseenEmptySeenFilledAgainstTruth) {
  const SeenRun& run = seenRun();
  CHECK(run.result.dem.has_value());
  const DemGrid& dem = *run.result.dem;
  const DemGrid truth = run.terrain.dem();
  const Vec3 g = run.scene.inputs.gimbal_site_m;
  long long unseen = 0, empty = 0, seen = 0, filled = 0;
  long long band[4][4] = {};
  long long wrong_class[3] = {};  // per 5 m band: unseen, empty, seen, filled
  constexpr int kStep = 3;  // every third cell each way: the ray cast is exact and slow
  for (int r = 0; r < dem.rows; r += kStep) {
    for (int c = 0; c < dem.cols; c += kStep) {
      const double n = dem.northOfRow(r), e = dem.eastOfCol(c);
      if (std::hypot(n - g.x(), e - g.y()) > 18.0) continue;
      double t = 0;
      if (!ortho::demElevation(truth, n, e, t)) continue;
      const bool has = dem.at(c, r) != dem.nodata;
      long long* b = band[std::min(3, static_cast<int>(std::hypot(n - g.x(), e - g.y()) / 5.0))];
      const int state = cellSeenByRayCast(run, truth, dem, c, r);
      if (state == products::kTruthMarginal) continue;
      const bool s = state == products::kTruthSeen;
      b[s ? 2 : 0] += 1;
      b[s ? 3 : 1] += has == s;
      if (!s && has) ++wrong_class[run.result.dem_seen[static_cast<std::size_t>(r) * dem.cols + c]];
      if (s) {
        ++seen;
        filled += has;
      } else {
        ++unseen;
        empty += !has;
      }
    }
  }
  const double unseen_empty = static_cast<double>(empty) / std::max(1LL, unseen);
  const double seen_filled = static_cast<double>(filled) / std::max(1LL, seen);
  const ground::TruthFigures& t = *run.report.truth;
  std::printf("\n  unseen in truth but filled: %lld interpolated, %lld measured", wrong_class[1], wrong_class[2]);
  for (int k = 0; k < 4; ++k)
    std::printf("\n  %d-%d m: %lld unseen, %.1f %% empty; %lld seen, %.1f %% filled", 5 * k, 5 * k + 5, band[k][0],
                100.0 * band[k][1] / std::max(1LL, band[k][0]), band[k][2], 100.0 * band[k][3] / std::max(1LL, band[k][2]));
  std::printf("\n  rocky tiny x4: ray cast: %lld cells unseen, %.2f %% empty; %lld seen, %.2f %% filled; report.json: "
              "%.2f %% / %.2f %%, ortho agreement %.2f %%\n",
              unseen, 100 * unseen_empty, seen, 100 * seen_filled, 100 * t.dem_unseen_empty.value_or(-1),
              100 * t.dem_seen_filled.value_or(-1), 100 * t.ortho_agreement.value_or(-1));
  CHECK(unseen > 1000);
  CHECK(seen > 1000);
  // Within 5 m (where 256-px images measure the ground densely) the seen ground stays filled.
  CHECK_TEXT(band[0][3] >= 0.95 * band[0][2], "seen cells within 5 m filled");
  // report.json's figures (their own sweep in the true DEM) against the ray cast.
  CHECK(t.dem_unseen_empty && t.dem_seen_filled && t.ortho_agreement);
  DOUBLES_EQUAL(unseen_empty, *t.dem_unseen_empty, 0.02);
  DOUBLES_EQUAL(seen_filled, *t.dem_seen_filled, 0.02);
  // The unseen side's goal: 95 % of the cells the true cameras do not see left empty.
  CHECK_TEXT(*t.dem_unseen_empty >= 0.95, "unseen cells empty");
  // The seen side: 71 % here, not 95 %. The ground beyond 10 m that these cameras see lies in the top rows of
  // their images, within the census window of the border, where the matcher makes no point (seen_check
  // SEEN_CHECK_BORDER: nearly all of the seen cells left empty lie within 8 px of the border of every image
  // that holds them); the rest of the seen ground is filled by each point's own reach (Kriging.hpp
  // local_reach) and the mask eroded by the census window only. With one reach for the cloud and an
  // 11-px mask this scene gave 62 %.
  CHECK_TEXT(*t.dem_seen_filled >= 0.68, "seen cells filled");
}

TEST(SeenCells, SeenRasterMatchesTheDem) {
  const SeenRun& run = seenRun();
  const DemGrid dem = readDemGeoTiff(run.out + "/dem.tif");
  const raster::Float32Raster seen = raster::readGeoTiff(run.out + "/dem_seen.tif");  // 8-bit, read as float
  CHECK(seen.nodata.has_value());
  DOUBLES_EQUAL(0.0, *seen.nodata, 0.0);
  CHECK_EQUAL(dem.cols, seen.geometry.cols);
  CHECK_EQUAL(dem.rows, seen.geometry.rows);
  DOUBLES_EQUAL(dem.east0_m, seen.geometry.east0_m, 1e-9);
  DOUBLES_EQUAL(dem.north0_m, seen.geometry.north0_m, 1e-9);
  DOUBLES_EQUAL(dem.cell_m, seen.geometry.cell_m, 1e-12);
  long long counts[3] = {0, 0, 0}, wrong = 0;
  for (std::size_t i = 0; i < dem.values.size(); ++i) {
    const int v = static_cast<int>(seen.values[i]);
    CHECK(v >= 0 && v <= dem::kCellMeasured && v == seen.values[i]);
    ++counts[v];
    wrong += (v == dem::kCellUnseen) != (dem.values[i] == dem.nodata);
  }
  std::printf("\n  dem_seen.tif: %lld unseen, %lld interpolated, %lld measured\n", counts[0], counts[1], counts[2]);
  CHECK_EQUAL(0, wrong);
  CHECK(counts[1] > 0 && counts[2] > 0);
}

TEST(SeenCells, OrthoPaintsOnlyFromImagesThatSeeTheCell) {
  const SeenRun& run = seenRun();
  const DemGrid dem = readDemGeoTiff(run.out + "/dem.tif");
  const DemGrid sigma = readDemGeoTiff(run.out + "/dem_sigma.tif");
  std::vector<ortho::OrthoSource> sources;
  for (const products::ProductImage& im : run.scene.inputs.images) sources.push_back({im.grey, im.model});
  ortho::OrthoOptions with, without;
  with.dem_sigma = &sigma;
  without.occlusion = false;
  const ortho::OrthoResult made = ortho::makeOrthoimage(dem, sources, with);
  const ortho::OrthoResult old = ortho::makeOrthoimage(dem, sources, without);
  long long painted = 0, hidden = 0, hidden_before = 0;
  for (int r = 0; r < dem.rows; r += 2) {
    for (int c = 0; c < dem.cols; c += 2) {
      const int k = made.source.at<int16_t>(r, c), k_old = old.source.at<int16_t>(r, c);
      if (k < 0 && k_old < 0) continue;
      const Vec3 x(dem.northOfRow(r), dem.eastOfCol(c), -static_cast<double>(dem.at(c, r)));
      if (k >= 0) {
        ++painted;
        hidden += products::terrainHides(dem, &sigma, sources[static_cast<std::size_t>(k)].model.c, x);
      }
      if (k_old >= 0) hidden_before += products::terrainHides(dem, &sigma, sources[static_cast<std::size_t>(k_old)].model.c, x);
    }
  }
  std::printf("\n  ortho: %lld cells painted, %lld from an image the DEM hides them from (without the rule: %lld)\n",
              painted, hidden, hidden_before);
  CHECK(painted > 1000);
  CHECK(hidden_before > 0);  // the scene has shadows that the rule has to keep out
  // The sweep's horizon is interpolated between cells: a cell at the very edge of a shadow may differ.
  CHECK(hidden <= painted / 1000);
}
