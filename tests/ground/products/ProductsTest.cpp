#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "ground/dataset/DemRaster.hpp"
#include "ground/ortho/Orthoimage.hpp"
#include "ground/products/Products.hpp"
#include "tests/ground/products/SimScene.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

const test::SimScene& tinyScene() {
  static const test::SimScene scene = test::makeSimScene("tiny", 4);
  return scene;
}

bool exists(const std::string& p) { return std::filesystem::exists(p); }

std::string readText(const std::string& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

bool hasWarning(const products::ProductsResult& r, const std::string& part) {
  for (const std::string& w : r.warnings) {
    if (w.find(part) != std::string::npos) return true;
  }
  return false;
}

}  // namespace

TEST_GROUP(Products){};

// The whole chain on a small rendered panorama with the true models: every product is written, the DEM
// agrees with the true surface within what 256-px images allow, the ortho and the report are made.
TEST(Products, TinyPanoramaMakesEveryProduct) {
  const test::SimScene& scene = tinyScene();
  const std::string out = test::scratchDir("products_tiny");
  ground::AdjustReport report;
  report.truth = ground::TruthFigures{};
  products::ProductOptions options;
  options.dense_max_disparity_px = 64;
  options.max_range_m = 18.0;  // the tiny terrain ends at 20 m
  const products::ProductsResult r = products::makeProducts(scene.inputs, options, out, &report);
  products::mergeIntoReport(r, report);
  for (const char* f : {"points.ply", "dem.tif", "dem_sigma.tif", "ortho.tif", "dem.png", "ortho.png", "report.html"}) {
    CHECK_TEXT(exists(out + "/" + f), f);
  }
  CHECK(exists(out + "/overlays/" + scene.inputs.images[0].stem + ".png"));
  CHECK_EQUAL(static_cast<int>(scene.inputs.pairs.size()), r.pairs_matched);
  CHECK(r.points > 10000);
  CHECK_EQUAL(r.points, r.dem_points);  // every point of the cloud reaches the DEM's bins
  CHECK(r.dem_rmse_m.has_value());
  CHECK(report.truth->dem_rmse_m.has_value());
  std::printf("\n  tiny x4 pairs: %lld points, DEM %dx%d cells of %.3f m, RMSE vs truth %.3f m, ortho seams %.2f px\n",
              r.points, r.dem->cols, r.dem->rows, r.dem->cell_m, *r.dem_rmse_m, r.ortho_seam_px);
  // 256-px images, f = 222 px, 20 cm base: a 0.3 px disparity error is ~10 cm of range at 4 m; the DEM
  // (over every cell kriged, out to the far field) must stay within decimetres of the truth.
  CHECK(*r.dem_rmse_m < 0.5);
  // The GeoTIFFs share the grid.
  const DemGrid dem = readDemGeoTiff(out + "/dem.tif");
  const DemGrid sigma = readDemGeoTiff(out + "/dem_sigma.tif");
  CHECK_EQUAL(dem.cols, sigma.cols);
  DOUBLES_EQUAL(r.dem->east0_m, dem.east0_m, 1e-9);
  const cv::Mat ortho = cv::imread(out + "/ortho.tif", cv::IMREAD_UNCHANGED);
  CHECK_EQUAL(dem.cols, ortho.cols);
  CHECK_EQUAL(dem.rows, ortho.rows);
  long long dem_cells = 0;
  for (float v : dem.values) dem_cells += v != dem.nodata;
  std::printf("  DEM cells %lld, ortho cells %d\n", dem_cells, cv::countNonZero(ortho));
  CHECK(cv::countNonZero(ortho) >= 0.9 * dem_cells);
  const std::string html = readText(out + "/report.html");
  CHECK(html.find("<svg") != std::string::npos);
  CHECK(html.find("data:image/png;base64,") != std::string::npos);
  CHECK(html.find("src='http") == std::string::npos);
  bool has_dem_stage = false;
  for (const auto& kv : report.seconds) has_dem_stage |= kv.first == "dem";
  CHECK(has_dem_stage);
}

// Bad input: an image missing, a model inconsistent with its image size, a pair without texture; each
// gives a warning naming it, and the other products are still made.
TEST(Products, BadInputIsReportedAndTheRestIsMade) {
  products::ProductInputs in = tinyScene().inputs;
  for (products::ProductImage& im : in.images) im.grey = im.grey.clone();  // cv::Mat copies share pixels
  in.images[0].grey = cv::Mat();  // pair 0 left missing
  in.images[3].model.width += 100;  // pair 1 right: model for another size
  in.images[4].grey.setTo(128);     // pair 2: no texture
  in.images[5].grey.setTo(128);
  const std::string out = test::scratchDir("products_bad");
  ground::AdjustReport report;
  products::ProductOptions options;
  options.dense_max_disparity_px = 64;
  const products::ProductsResult r = products::makeProducts(in, options, out, &report);
  products::mergeIntoReport(r, report);
  CHECK(hasWarning(r, "image " + in.images[0].stem + ": missing"));
  CHECK(hasWarning(r, "model " + in.images[3].stem + ": size"));
  CHECK(hasWarning(r, "pair " + std::to_string(in.pairs[2].id) + ": no valid dense matches"));
  CHECK_EQUAL(1, r.pairs_matched);
  for (const char* f : {"points.ply", "dem.tif", "ortho.tif", "dem.png", "report.html"}) {
    CHECK_TEXT(exists(out + "/" + f), f);
  }
  CHECK(readText(out + "/report.html").find("missing") != std::string::npos);
  CHECK_EQUAL(report.warnings.size(), r.warnings.size());
}

// A scene with no valid matches at all: no cloud, no DEM, no ortho, but the previews of the images and
// report.html are still made and say why.
TEST(Products, NoValidMatchesStillWritesTheReport) {
  products::ProductInputs in = tinyScene().inputs;
  for (products::ProductImage& im : in.images) im.grey = im.grey.clone();  // cv::Mat copies share pixels
  for (products::ProductImage& im : in.images) im.grey.setTo(90);
  const std::string out = test::scratchDir("products_none");
  ground::AdjustReport report;
  products::ProductOptions options;
  options.dense_max_disparity_px = 64;
  const products::ProductsResult r = products::makeProducts(in, options, out, &report);
  products::mergeIntoReport(r, report);
  CHECK_EQUAL(0, r.pairs_matched);
  CHECK_EQUAL(0, r.points);
  CHECK(!exists(out + "/dem.tif"));
  CHECK(exists(out + "/report.html"));
  CHECK(hasWarning(r, "no dense points"));
}
