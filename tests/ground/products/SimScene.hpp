// A rendered synthetic panorama in memory (ground/sim), with true models and the true DEM, as product
// inputs. Shared by the products and ortho tests.
#pragma once

#include <cstdlib>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "ground/products/Products.hpp"
#include "ground/sim/Renderer.hpp"
#include "ground/sim/SimGeometry.hpp"
#include "ground/sim/Terrain.hpp"

namespace areomap::test {

struct SimScene {
  sim::SimGeometry geometry;
  products::ProductInputs inputs;  // true models, true ties (the geometry's check points)
};

// Diagnostic knob of the scene tests: when the environment variable `name` is set (e.g. AREOMAP_FAR_SEED=2),
// the terrain of that seed instead of the preset's.
inline void seedFromEnvironment(sim::SimConfig& config, const char* name) {
  if (const char* seed = std::getenv(name)) config.seed = static_cast<uint64_t>(std::atoll(seed));
}

// `preset` with `pairs` pairs (0 = the preset's count); `edit` may change the configuration first.
inline SimScene makeSimScene(const std::string& preset, int pairs, void (*edit)(sim::SimConfig&) = nullptr) {
  sim::SimConfig config = sim::presetConfig(preset);
  if (pairs > 0) sim::setPairCount(config, pairs);
  if (edit != nullptr) edit(config);
  const sim::Terrain terrain = sim::Terrain::build(config);
  SimScene s;
  s.geometry = sim::makeGeometry(config, terrain);
  s.inputs.site = "sim-" + preset;
  s.inputs.gimbal_site_m = s.geometry.gimbal_m;
  s.inputs.truth_dem = terrain.dem();
  int index = 0;
  for (const sim::SimPair& p : s.geometry.pairs) {
    products::ProductPair pp;
    pp.id = p.id;
    pp.sol = p.sol;
    for (const sim::SimCamera* cam : {&p.left, p.right ? &*p.right : nullptr}) {
      if (cam == nullptr) continue;
      const sim::RenderedImage r = sim::renderImage(terrain, config, cam->truth, index);
      products::ProductImage im;
      im.stem = cam->stem;
      im.grey = cv::Mat(r.height, r.width, CV_8U, const_cast<uint8_t*>(r.pixels.data())).clone();
      im.model = cam->truth;
      (cam == &p.left ? pp.left : pp.right) = static_cast<int>(s.inputs.images.size());
      s.inputs.images.push_back(im);
      ++index;
    }
    s.inputs.pairs.push_back(pp);
  }
  for (const ImageObservation& o : s.geometry.observations) {
    for (std::size_t i = 0; i < s.inputs.images.size(); ++i) {
      if (s.inputs.images[i].stem != o.image) continue;
      products::ProductTie t;
      t.point = static_cast<int>(o.point);
      t.image = static_cast<int>(i);
      t.pixel_px = Vec2(o.sample_px, o.line_px);
      t.residual_px = 0.0;
      s.inputs.ties.push_back(t);
    }
  }
  // Inter-stereo: a point seen from more than one pair.
  std::map<int, std::set<int>> pairs_of_point;
  for (const products::ProductTie& t : s.inputs.ties) pairs_of_point[t.point].insert(t.image / 2);
  for (products::ProductTie& t : s.inputs.ties) t.inter = pairs_of_point[t.point].size() > 1;
  return s;
}

// "Seen in truth": some true camera of `in` projects the ground point inside its image, the
// pixel's own ray passes through the point (1e-6 rad; the inverse converges to 1e-9: CAHVOR distortion
// folds points ~76 degrees off the axis into the image, which the camera does not see), and
// `clear(camera centre, unit direction, distance)` finds no terrain between the camera and the point (each
// test says how it casts the ray).
template <class Clear>
bool seenInTruth(const products::ProductInputs& in, const Vec3& point, const Clear& clear) {
  for (const products::ProductImage& im : in.images) {
    Vec2 px;
    if (project(im.model, point, px) != Status::kOk) continue;
    if (px.x() < 0 || px.y() < 0 || px.x() > im.grey.cols - 1 || px.y() > im.grey.rows - 1) continue;
    Vec3 o, u;
    if (unproject(im.model, px, o, u) != Status::kOk || (point - o).normalized().cross(u).norm() > 1e-6)
      continue;
    const Vec3 d = point - im.model.c;
    const double dist = d.norm();
    if (clear(im.model.c, Vec3(d / dist), dist)) return true;
  }
  return false;
}

// seenInTruth with the ray cast exactly against the true terrain (sim::Terrain::castRay): the ray from the
// camera reaches the point before hitting the terrain elsewhere (3 cm).
inline bool seenInTerrain(const products::ProductInputs& in, const sim::Terrain& terrain, const Vec3& point) {
  return seenInTruth(in, point, [&terrain](const Vec3& c, const Vec3& u, double dist) {
    double t = 0;
    return terrain.castRay(c, u, t, dist + 1.0) && t >= dist - 0.03;
  });
}

}  // namespace areomap::test
