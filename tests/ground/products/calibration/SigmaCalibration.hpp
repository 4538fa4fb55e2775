// The DEM sigma against the simulator's true DEM, per range band, on a reduced navcam scene rendered at
// an image noise and blur the products are not told about (SigmaCalibrationTest, SigmaFollowsNoiseTest).
// Each band (2-5 m, 5-10 m from the gimbal centre) counts the cells some true camera sees and, of those
// the DEM fills, the ones whose error lies within the DEM's own sigma.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "ground/dataset/DemRaster.hpp"
#include "ground/ortho/Orthoimage.hpp"
#include "ground/products/Products.hpp"
#include "tests/ground/products/SimScene.hpp"
#include "tests/support/TestData.hpp"

namespace areomap::test {

// What differs from the navcam preset: terrain out to 14 m, `pairs` pairs, the images' size, the seed, the
// relief and rocks (relative to the preset's), and the rendering's sensor noise and optical blur.
struct CalibrationScene {
  uint64_t seed = 1;
  double roughness = 1.0;
  int pairs = 2;
  int size_px = 1024;  // width = height
  double noise_dn = 1.5;
  double blur_px = 0.0;
};

struct BandFigures {
  long long seen = 0, filled = 0, within = 0;
  double s2 = 0, sig2 = 0;
  double within1Sigma() const { return filled > 0 ? static_cast<double>(within) / filled : 0.0; }
  double rmseM() const { return filled > 0 ? std::sqrt(s2 / filled) : 0.0; }
  double sigmaRmsM() const { return filled > 0 ? std::sqrt(sig2 / filled) : 0.0; }
};

struct CalibrationFigures {
  BandFigures bands[2];                             // 2-5 m, 5-10 m
  std::vector<ground::DensePairNoise> dense_pairs;  // each pair's estimated matching noise
};

namespace detail {
inline CalibrationScene g_scene;
inline void editScene(sim::SimConfig& c) {
  c.half_extent_m = 14.0;
  c.max_range_m = 12.0;
  c.seed = g_scene.seed;
  c.relief_m *= g_scene.roughness;
  c.rock_k = std::min(0.5, c.rock_k * g_scene.roughness);
  c.width = c.height = g_scene.size_px;
  c.noise_dn = g_scene.noise_dn;
  c.blur_px = g_scene.blur_px;
}
}  // namespace detail

// The scene through the products (true models; the options leave the matching noise to the pair's own
// estimate) and its DEM against the truth.
inline CalibrationFigures runCalibrationScene(const CalibrationScene& s) {
  detail::g_scene = s;
  sim::SimConfig config = sim::presetConfig("navcam");
  sim::setPairCount(config, s.pairs);
  detail::editScene(config);
  const sim::Terrain terrain = sim::Terrain::build(config);
  const SimScene scene = makeSimScene("navcam", s.pairs, &detail::editScene);
  const std::string out = scratchDir("sigma_calibration");
  products::ProductOptions options;
  options.max_range_m = 12.5;
  if (const char* c = std::getenv("AREOMAP_CALIBRATION_CELL_M")) options.cell_m = std::atof(c);
  const products::ProductsResult result = products::makeProducts(scene.inputs, options, out);
  CalibrationFigures fig;
  fig.dense_pairs = result.dense_pairs;
  if (!result.dem) return fig;
  const DemGrid& dem = *result.dem;
  const DemGrid sigma = readDemGeoTiff(out + "/dem_sigma.tif");
  const DemGrid truth = terrain.dem();
  const Vec3 g = scene.inputs.gimbal_site_m;
  for (int r = 0; r < dem.rows; ++r) {
    for (int c = 0; c < dem.cols; ++c) {
      const double n = dem.northOfRow(r), e = dem.eastOfCol(c);
      const double range = std::hypot(n - g.x(), e - g.y());
      BandFigures* b = range >= 2 && range < 5    ? &fig.bands[0]
                       : range >= 5 && range < 10 ? &fig.bands[1]
                                                  : nullptr;
      if (b == nullptr) continue;
      double t = 0;
      if (!ortho::demElevation(truth, n, e, t)) continue;
      const bool seen =
          seenInTruth(scene.inputs, Vec3(n, e, -t), [&](const Vec3& o, const Vec3& u, double d) {
            double hit = 0;
            return terrain.castRay(o, u, hit, d + 1.0) && hit >= d - 0.03;
          });
      if (!seen) continue;
      ++b->seen;
      const float v = dem.at(c, r);
      if (v == dem.nodata) continue;
      ++b->filled;
      const double err = v - t, sd = sigma.at(c, r);
      b->s2 += err * err;
      b->sig2 += sd * sd;
      b->within += std::fabs(err) <= sd;
    }
  }
  return fig;
}

// One table row: the level, each pair's matching sigma (and its source), per band RMSE, sigma RMS and the
// fraction within 1 sigma.
inline void printCalibrationRow(const char* label, const CalibrationFigures& f) {
  std::printf("| %s |", label);
  for (const ground::DensePairNoise& p : f.dense_pairs)
    std::printf(" %.3f px (%s, %lld)", p.match_sigma_px, p.match_sigma_source.c_str(), p.samples);
  std::printf(" |");
  for (const BandFigures& b : f.bands)
    std::printf(" %.4f m, %.4f m, %.1f %% (%lld cells) |", b.rmseM(), b.sigmaRmsM(), 100 * b.within1Sigma(),
                b.filled);
  std::printf("\n");
  std::fflush(stdout);
}

}  // namespace areomap::test
