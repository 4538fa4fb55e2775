// The products on the navcam preset (1024x1024, 45 degrees, 20 cm base), reduced so that the default
// test run stays short: 2 pairs and terrain out to 14 m (the full navcam pass is a benchmark). Models are
// the TRUE models (they stand in for the adjusted ones: the adjustment is tested in ground/adjust), so
// the common datum rotation is zero and the "datum removed" figures equal the raw ones.
//  - DEM vs the true DEM over cells that the cameras see in truth (ray cast in the true terrain):
//    RMSE <= 3 cm at 2-5 m, <= 10 cm at 5-10 m from the gimbal centre, >= 95 % filled, 50-80 % of the
//    errors within 1 sigma in EACH band (and over 2-10 m): the sigma of dem::krigeDem with the matcher's
//    error correlation (dense::kMatchErrorCorrelationPx), no factor calibrated on the truth.
//  - The points' own sigmas against their actual height errors (the calibration of dense::kMatchSigmaPx).
//  - Orthoimage from the made DEM vs one from the true DEM: shift <= 0.5 cell within 10 m; seams <= 0.5 px.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "ground/dataset/DemRaster.hpp"
#include "ground/dense/DenseMatcher.hpp"
#include "ground/dense/Triangulation.hpp"
#include "ground/ortho/Orthoimage.hpp"
#include "ground/products/Products.hpp"
#include "tests/ground/products/SimScene.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

void reduce(sim::SimConfig& c) {
  c.half_extent_m = 14.0;
  c.max_range_m = 12.0;
  test::seedFromEnvironment(c, "AREOMAP_NAVCAM_SEED");  // diagnostic knob
}

struct NavcamRun {
  test::SimScene scene;
  sim::Terrain terrain;
  products::ProductsResult result;
  DemGrid sigma;
  std::string out;  // the products folder
};

const NavcamRun& navcam() {
  static const NavcamRun run = [] {
    NavcamRun r;
    sim::SimConfig config = sim::presetConfig("navcam");
    sim::setPairCount(config, 2);
    reduce(config);
    r.terrain = sim::Terrain::build(config);
    r.scene = test::makeSimScene("navcam", 2, &reduce);
    const std::string out = test::scratchDir("products_navcam");
    r.out = out;
    ground::AdjustReport report;
    products::ProductOptions options;
    options.max_range_m = 12.5;
    r.result = products::makeProducts(r.scene.inputs, options, out, &report);
    products::mergeIntoReport(r.result, report);
    r.sigma = readDemGeoTiff(out + "/dem_sigma.tif");
    for (const auto& kv : report.seconds) std::printf("  stage %-12s %7.2f s\n", kv.first.c_str(), kv.second);
    return r;
  }();
  return run;
}

// A ground point is seen in truth (test::seenInTruth) when the ray from the camera reaches it before
// hitting the terrain elsewhere.
bool seenInTruth(const NavcamRun& run, const Vec3& point) {
  return test::seenInTerrain(run.scene.inputs, run.terrain, point);
}

}  // namespace

TEST_GROUP(NavcamProducts){};

TEST(NavcamProducts, DemAgainstTruthOverSeenCells) {
  const NavcamRun& run = navcam();
  CHECK(run.result.dem.has_value());
  const DemGrid& dem = *run.result.dem;
  const DemGrid truth = run.terrain.dem();
  const Vec3 g = run.scene.inputs.gimbal_site_m;
  struct Band {
    double lo, hi, s2 = 0, sig2 = 0;
    long long seen = 0, filled = 0, within = 0;
    std::vector<double> abs_err;
  } bands[2] = {{2.0, 5.0, 0, 0, 0, 0, 0, {}}, {5.0, 10.0, 0, 0, 0, 0, 0, {}}};
  for (int r = 0; r < dem.rows; ++r) {
    for (int c = 0; c < dem.cols; ++c) {
      const double n = dem.northOfRow(r), e = dem.eastOfCol(c);
      const double range = std::hypot(n - g.x(), e - g.y());
      Band* b = range >= 2 && range < 5 ? &bands[0] : range >= 5 && range < 10 ? &bands[1] : nullptr;
      if (b == nullptr) continue;
      double t = 0;
      if (!ortho::demElevation(truth, n, e, t)) continue;
      if (!seenInTruth(run, Vec3(n, e, -t))) continue;
      ++b->seen;
      const float v = dem.at(c, r);
      if (v == dem.nodata) continue;
      ++b->filled;
      const double err = v - t;
      b->s2 += err * err;
      b->abs_err.push_back(std::fabs(err));
      if (std::fabs(err) <= run.sigma.at(c, r)) ++b->within;
      b->sig2 += static_cast<double>(run.sigma.at(c, r)) * run.sigma.at(c, r);
    }
  }
  bool ok[2][4];
  int k = 0;
  for (Band& b : bands) {
    std::sort(b.abs_err.begin(), b.abs_err.end());
    const auto quantile = [&b](double q) {
      return b.abs_err.empty() ? 0.0 : b.abs_err[static_cast<std::size_t>(q * (b.abs_err.size() - 1))];
    };
    std::printf("\n  %.0f-%.0f m |error| quantiles: 50 %% %.4f m, 68 %% %.4f m, 80 %% %.4f m, 95 %% %.4f m", b.lo, b.hi,
                quantile(0.5), quantile(0.68), quantile(0.8), quantile(0.95));
    const double rmse = std::sqrt(b.s2 / std::max(1LL, b.filled));
    const double filled = static_cast<double>(b.filled) / std::max(1LL, b.seen);
    const double within = static_cast<double>(b.within) / std::max(1LL, b.filled);
    std::printf("\n  navcam (2 pairs, true models) %.0f-%.0f m: %lld seen cells, %.1f %% filled, RMSE %.4f m "
                "(datum removed: %.4f m, no datum rotation with true models), sigma RMS %.4f m, %.1f %% of errors "
                "within 1 sigma (datum removed: the same)",
                b.lo, b.hi, b.seen, 100 * filled, rmse, rmse, std::sqrt(b.sig2 / std::max(1LL, b.filled)), 100 * within);
    ok[k][0] = b.seen > 1000;
    ok[k][1] = filled >= 0.95;
    ok[k][2] = rmse <= (b.lo < 3 ? 0.03 : 0.10);
    ok[k][3] = within >= 0.5 && within <= 0.8;
    ++k;
  }
  // Sigma honesty per band (above) and over all seen cells 2-10 m.
  const double within_all = static_cast<double>(bands[0].within + bands[1].within) /
                            std::max(1LL, bands[0].filled + bands[1].filled);
  std::printf("\n  all seen cells 2-10 m: %.1f %% of errors within 1 sigma\n", 100 * within_all);
  CHECK_TEXT(within_all >= 0.5 && within_all <= 0.8, "50-80 % within 1 sigma over 2-10 m");
  for (int i = 0; i < 2; ++i) {
    CHECK_TEXT(ok[i][0], "seen cells");
    CHECK_TEXT(ok[i][1], "filled >= 95 %");
    CHECK_TEXT(ok[i][2], "RMSE");
    CHECK_TEXT(ok[i][3], "50-80 % within 1 sigma");
  }
}

TEST(NavcamProducts, OrthoAgreesWithTruthOrtho) {
  const NavcamRun& run = navcam();
  CHECK(run.result.dem.has_value());
  const DemGrid& dem = *run.result.dem;
  // The truth ortho on the same grid: the true DEM sampled at the cell centres.
  DemGrid true_grid = dem;
  const DemGrid truth = run.terrain.dem();
  for (int r = 0; r < dem.rows; ++r) {
    for (int c = 0; c < dem.cols; ++c) {
      double t = 0;
      true_grid.at(c, r) = ortho::demElevation(truth, dem.northOfRow(r), dem.eastOfCol(c), t) ? static_cast<float>(t)
                                                                                              : dem.nodata;
    }
  }
  std::vector<ortho::OrthoSource> sources;
  for (const products::ProductImage& im : run.scene.inputs.images) sources.push_back({im.grey, im.model});
  // The DEM's geometry alone: both without the occlusion rule, whose shadows would leave too few whole
  // tiles (the rule is checked by SeenCells).
  ortho::OrthoOptions geometry_only;
  geometry_only.occlusion = false;
  const ortho::OrthoResult made = ortho::makeOrthoimage(dem, sources, geometry_only);
  const ortho::OrthoResult ref = ortho::makeOrthoimage(true_grid, sources, geometry_only);
  // Within 10 m of the gimbal centre.
  cv::Mat mask = cv::Mat::zeros(dem.rows, dem.cols, CV_8U);
  const Vec3 g = run.scene.inputs.gimbal_site_m;
  for (int r = 0; r < dem.rows; ++r)
    for (int c = 0; c < dem.cols; ++c)
      if (std::hypot(dem.northOfRow(r) - g.x(), dem.eastOfCol(c) - g.y()) < 10.0) mask.at<uint8_t>(r, c) = 255;
  double se = 0, ss = 0, rms = 0;
  const int tiles = ortho::orthoShift(made.image, ref.image, mask, 32, 4, se, ss, &rms);
  std::printf("\n  ortho (made DEM) vs truth ortho within 10 m: %d tiles, median shift %.3f east %.3f south cells "
              "(RMS %.3f cells, cell %.3f m); seams: %lld cells, %lld checked, %.3f px RMS (95 %% %.3f px), grey "
              "RMS %.1f\n",
              tiles, se, ss, rms, dem.cell_m, made.seams.seam_cells, made.seams.checked, made.seams.geometric_rms_px,
              made.seams.geometric_p95_px, made.seams.grey_rms);
  std::printf("  seams median %.3f px (made DEM), %.3f px (true DEM: the estimator's floor; RMS %.3f px)\n",
              made.seams.geometric_median_px, ref.seams.geometric_median_px, ref.seams.geometric_rms_px);
  CHECK(tiles >= 20);
  CHECK(std::hypot(se, ss) <= 0.5);
  CHECK(made.seams.checked >= 20);
  CHECK(made.seams.geometric_median_px <= 0.5);
}

// The points' own sigma (the matcher's sub-pixel precision, dense::kMatchSigmaPx, propagated through the
// intersection) against their actual height errors: each point of points.ply against the true DEM at its
// (north, east). Robust figures (the cloud keeps some mismatches): the median of |error| / sigma over
// 0.6745 (1 for an honest Gaussian sigma) and the share of points within 1 sigma (68 % for one).
TEST(NavcamProducts, PointSigmaAgainstTruth) {
  const NavcamRun& run = navcam();
  const std::vector<dense::CloudPoint> cloud = dense::readPly(run.out + "/points.ply");
  const DemGrid truth = run.terrain.dem();
  const Vec3 g = run.scene.inputs.gimbal_site_m;
  struct Band {
    double lo, hi;
    std::vector<double> ratio;
    double e2 = 0, s2 = 0, robust = 0, within = 0;
  } bands[2] = {{2.0, 5.0, {}, 0, 0, 0, 0}, {5.0, 10.0, {}, 0, 0, 0, 0}};
  for (const dense::CloudPoint& p : cloud) {
    const double range = std::hypot(p.site_m.x() - g.x(), p.site_m.y() - g.y());
    Band* b = range >= 2 && range < 5 ? &bands[0] : range >= 5 && range < 10 ? &bands[1] : nullptr;
    double t = 0;
    if (b == nullptr || !(p.sigmaHeight_m() > 0) || !ortho::demElevation(truth, p.site_m.x(), p.site_m.y(), t)) continue;
    const double e = -p.site_m.z() - t;
    b->ratio.push_back(std::fabs(e) / p.sigmaHeight_m());
    b->e2 += e * e;
    b->s2 += p.sigmaHeight_m() * p.sigmaHeight_m();
  }
  for (Band& b : bands) {
    const std::size_t n = b.ratio.size();
    CHECK(n > 1000);
    std::sort(b.ratio.begin(), b.ratio.end());
    b.robust = b.ratio[n / 2] / 0.6745;
    b.within = static_cast<double>(std::upper_bound(b.ratio.begin(), b.ratio.end(), 1.0) - b.ratio.begin()) / n;
    std::printf("\n  points %.0f-%.0f m: %zu, height error RMS %.4f m, sigma RMS %.4f m (ratio %.2f), robust "
                "error/sigma %.2f, %.1f %% within 1 sigma (sigma from %.2f px)",
                b.lo, b.hi, n, std::sqrt(b.e2 / n), std::sqrt(b.s2 / n), std::sqrt(b.e2 / b.s2), b.robust,
                100 * b.within, dense::kMatchSigmaPx);
  }
  std::printf("\n");
  for (const Band& b : bands) {
    CHECK_TEXT(b.robust > 0.7 && b.robust < 1.4, "robust error/sigma within 0.7-1.4");
    CHECK_TEXT(b.within > 0.5 && b.within < 0.85, "50-85 % of point errors within 1 sigma");
  }
}
