// The ground pass on synthetic frames the simulator does not make, with truth (a textured ground plane):
// the Perseverance Navcam's fisheye-linearity CAHVORE (a real model, its real R and E, type 2 parameter 0)
// at full detector resolution (5120 x 3840), and as half-resolution quarter-sensor tiles whose principal
// point lies at a corner of the tile (the upper-left quarter, as the shared real tiles) or at the opposite
// corner (the lower-right quarter). Ties are checked against the plane, the whole pass (adjustment,
// rectification, dense matching, DEM) against its elevation and coverage.
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "ground/dataset/DemRaster.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/io/Panorama.hpp"
#include "ground/pass/GroundPass.hpp"
#include "ground/pass/PassProducts.hpp"
#include "ground/ties/FullResolutionTies.hpp"
#include "ground/ties/TieRunner.hpp"
#include "tests/ground/pass/PassChecks.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

using test::detector;
using test::navcam;
using test::tile;

constexpr double kPlaneZ_m = 0.0;  // the rover navigation frame's ground level

io::Panorama syntheticPair(const CameraModel& left, const CameraModel& right, const std::string& name,
                           unsigned seed) {
  io::Panorama p;
  p.dataset.root = test::scratchDir("synthetic-frames-" + name);
  p.dataset.name = name;
  Pair pair;
  pair.id = 0;
  pair.sol = 1;
  pair.left.stem = name + "_L";
  pair.left.image_path = p.dataset.root + "/" + pair.left.stem + ".png";
  ImageRef r;
  r.stem = name + "_R";
  r.image_path = p.dataset.root + "/" + r.stem + ".png";
  pair.right = r;
  p.dataset.pairs.push_back(pair);
  p.left.push_back(io::PanoramaImage{pair.left.stem, pair.left.image_path,
                                     test::renderPlane(left, kPlaneZ_m, seed), left});
  p.right.push_back(
      io::PanoramaImage{r.stem, r.image_path, test::renderPlane(right, kPlaneZ_m, seed), right});
  return p;
}

struct TieTruth {
  int ties = 0;
  double rms_px = 0.0;  // right observation against the truth projection of the left one's plane point
  int quadrants = 0;    // quadrants of the left image holding ties
};

TieTruth checkTies(const io::Panorama& p, const TieRun& run) {
  TieTruth t;
  std::vector<Vec2> left(run.points_m.size(), Vec2(NAN, NAN)), right = left;
  for (const ImageObservation& o : run.observations) {
    (o.image == p.left[0].stem ? left : right)[o.point] = Vec2(o.sample_px, o.line_px);
  }
  double sum = 0.0;
  bool quadrant[4] = {};
  for (std::size_t i = 0; i < left.size(); ++i) {
    Vec3 ground;
    Vec2 truth;
    if (std::isnan(left[i].x()) || std::isnan(right[i].x())) continue;
    if (!test::planePoint(p.left[0].model, left[i], kPlaneZ_m, ground) ||
        !ok(project(p.right[0]->model, ground, truth)))
      continue;
    sum += (right[i] - truth).squaredNorm();
    ++t.ties;
    quadrant[(left[i].x() > 0.5 * p.left[0].model.width ? 1 : 0) +
             (left[i].y() > 0.5 * p.left[0].model.height ? 2 : 0)] = true;
  }
  t.rms_px = t.ties > 0 ? std::sqrt(sum / t.ties) : 0.0;
  for (bool q : quadrant) t.quadrants += q ? 1 : 0;
  return t;
}

}  // namespace

TEST_GROUP(SyntheticFrames){};

// A full-resolution 5120 x 3840 CAHVORE pair: ties over the whole frame, each at full-resolution
// precision after the binned match (the 5x binned match alone is good to a few tenths of a full pixel).
TEST(SyntheticFrames, FullDetectorFrameTies) {
  const io::Panorama p = syntheticPair(detector(false), detector(true), "detector", 11);
  const TieRun run = runTiePoints(p, false);
  LONGS_EQUAL(5, run.binning);
  const TieTruth t = checkTies(p, run);
  std::printf("\n5120x3840: %d ties, %.3f px RMS against the plane, %d quadrants, %d refined, %d left out\n",
              t.ties, t.rms_px, t.quadrants, run.refine.refined, run.refine.dropped);
  CHECK(t.ties >= 60);
  CHECK(t.rms_px <= 0.2);
  CHECK(t.quadrants >= 3);
}

namespace {

// The whole pass on a tile pair: ties against the plane, then the DEM against the plane's elevation over
// what both cameras see at 2-10 m.
void tilePass(double x0, double y0, const std::string& name, unsigned seed) {
  const io::Panorama p = syntheticPair(tile(false, x0, y0), tile(true, x0, y0), name, seed);
  const TieRun run = runTiePoints(p, false);
  const TieTruth t = checkTies(p, run);
  ground::GroundPassOptions options;
  options.out_dir = p.dataset.root + "/out";
  options.progress = false;
  options.products = true;
  (void)ground::runGroundPass(p.dataset, options, nullptr, nullptr, std::make_shared<const io::Panorama>(p));
  const DemGrid dem = readDemGeoTiff(options.out_dir + "/dem.tif");
  const CameraModel l = io::readCameraModelFile(options.out_dir + "/models/" + p.left[0].stem + ".cahvor");
  const CameraModel r = io::readCameraModelFile(options.out_dir + "/models/" + p.right[0]->stem + ".cahvor");
  const double cover = test::demCoverage(dem, l, r, 2.0, 10.0);
  std::vector<double> dz;
  for (int row = 0; row < dem.rows; ++row) {
    for (int col = 0; col < dem.cols; ++col) {
      const float v = dem.at(col, row);
      const double range = std::hypot(dem.northOfRow(row) - l.c.x(), dem.eastOfCol(col) - l.c.y());
      if (v != dem.nodata && std::isfinite(v) && range >= 2.0 && range < 10.0)
        dz.push_back(std::fabs(v + kPlaneZ_m));
    }
  }
  std::sort(dz.begin(), dz.end());
  const double median = dz.empty() ? 1e9 : dz[dz.size() / 2];
  std::printf(
      "\n%s: %d ties, %.3f px RMS against the plane, %d quadrants; DEM 2-10 m: coverage %.1f %%, median |dz| "
      "%.4f m over %zu cells\n",
      name.c_str(), t.ties, t.rms_px, t.quadrants, 100.0 * cover, median, dz.size());
  CHECK(t.ties >= 40);
  CHECK(t.rms_px <= 0.2);
  CHECK(cover >= 0.9);
  CHECK(median <= 0.01);
}

}  // namespace

// The upper-left quarter of the sensor: the principal point at the tile's lower-right corner (A.H ~ 1297).
TEST(SyntheticFrames, TileWithPrincipalPointAtItsCorner) {
  tilePass(0.0, 0.0, "tile-ul", 21);
}

// The lower-right quarter: the principal point at the opposite (upper-left) corner.
TEST(SyntheticFrames, TileWithPrincipalPointAtTheOppositeCorner) {
  tilePass(2544.0, 1904.0, "tile-lr", 22);
}
