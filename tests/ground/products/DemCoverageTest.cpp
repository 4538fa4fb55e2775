// ground/products DemCoverage on a scene whose answer is known by construction: a level ground under a
// stereo pair of pinhole cameras, DEMs with planted holes, and a ground plane fitted to known points.
#include <cmath>
#include <random>
#include <vector>

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/DemRaster.hpp"
#include "ground/products/DemCoverage.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using products::CoverageCount;
using products::GroundPlane;

namespace {

constexpr double kHeightM = 1.5;  // cameras above the level ground (up = 0)

// A 640x480 pinhole camera (f = 500 px) at `east` looking north, pitched down by `pitch_deg`.
CameraModel camera(double east_m, double pitch_deg) {
  const double p = pitch_deg * M_PI / 180.0;
  CameraModel m;
  m.type = CameraType::kCahv;
  m.c = Vec3(0.0, east_m, -kHeightM);  // site frame: +X north, +Y east, +Z down
  m.a = Vec3(std::cos(p), 0.0, std::sin(p));
  const Vec3 right(0.0, 1.0, 0.0), down(-std::sin(p), 0.0, std::cos(p));
  m.h = 500.0 * right + 319.5 * m.a;
  m.v = 500.0 * down + 239.5 * m.a;
  m.width = 640;
  m.height = 480;
  return m;
}

// A level DEM (up = 0) of 5 cm cells, 30 m x 30 m around the cameras, filled beyond `from_m` of them.
DemGrid levelDem(double from_m = 0.0) {
  DemGrid d;
  d.cell_m = 0.05;
  d.cols = d.rows = 600;
  d.east0_m = -15.0;
  d.north0_m = 15.0;
  d.values.assign(static_cast<std::size_t>(d.cols) * d.rows, d.nodata);
  for (int row = 0; row < d.rows; ++row)
    for (int col = 0; col < d.cols; ++col)
      if (std::hypot(d.northOfRow(row), d.eastOfCol(col)) >= from_m) d.at(col, row) = 0.0f;
  return d;
}

GroundPlane planeOf(const DemGrid& dem) {
  GroundPlane plane;
  CHECK(products::groundPlane(dem, Vec3(0.0, 0.0, -kHeightM), 20.0, plane));
  return plane;
}

}  // namespace

TEST_GROUP(DemCoverage) {};

TEST(DemCoverage, AFullDemCoversWhatTheCamerasSee) {
  const DemGrid dem = levelDem();
  const CoverageCount c = products::demCoverage(dem, nullptr, camera(0.0, 25.0), camera(0.4, 25.0), planeOf(dem),
                                                2.0, 10.0);
  CHECK(c.seen > 1000);
  LONGS_EQUAL(c.seen, c.filled);
}

TEST(DemCoverage, AHoleInViewCountsAsUncovered) {
  DemGrid dem = levelDem();
  const CameraModel l = camera(0.0, 25.0), r = camera(0.4, 25.0);
  const CoverageCount full = products::demCoverage(dem, nullptr, l, r, planeOf(dem), 5.0, 10.0);
  // A 1 m x 1 m hole at 6-7 m straight ahead: 400 cells, all in both views.
  long hole = 0;
  for (int row = 0; row < dem.rows; ++row)
    for (int col = 0; col < dem.cols; ++col)
      if (dem.northOfRow(row) > 6.0 && dem.northOfRow(row) < 7.0 && std::abs(dem.eastOfCol(col) - 0.2) < 0.5) {
        dem.at(col, row) = dem.nodata;
        ++hole;
      }
  LONGS_EQUAL(400, hole);
  const CoverageCount c = products::demCoverage(dem, nullptr, l, r, planeOf(dem), 5.0, 10.0);
  LONGS_EQUAL(full.seen, c.seen);
  LONGS_EQUAL(full.seen - hole, c.filled);
}

TEST(DemCoverage, AnEmptyNearRangeUnderACertainPlaneIsUncovered) {
  // The DEM starts at 8 m; its plane is exact, so the empty ground at 5-8 m is seen for certain.
  const DemGrid dem = levelDem(8.0);
  const GroundPlane plane = planeOf(dem);
  DOUBLES_EQUAL(0.0, plane.sigmaUp(6.0, 0.0), 1e-9);
  const CoverageCount c = products::demCoverage(dem, nullptr, camera(0.0, 25.0), camera(0.4, 25.0), plane, 5.0,
                                                10.0);
  CHECK(c.seen > 1000);
  CHECK(c.fraction() < 0.7);
}

TEST(DemCoverage, AnUncertainGroundIsNotSeenAtTheEdgeOfTheView) {
  // The lowest image row sees the level ground at about 5.4 m (pitch up 10 degrees), the DEM starts at 7 m
  // and the plane behind the empty cells is uncertain: empty cells so close to the edge of the view that
  // the ground's uncertainty could take them out of it are not counted; those well inside still are.
  const CameraModel l = camera(0.0, -10.0), r = camera(0.4, -10.0);
  const DemGrid dem = levelDem(7.0);
  GroundPlane exact = planeOf(dem), rough = exact;
  rough.sigma_m = 0.1;
  const CoverageCount certain = products::demCoverage(dem, nullptr, l, r, exact, 5.0, 10.0);
  const CoverageCount uncertain = products::demCoverage(dem, nullptr, l, r, rough, 5.0, 10.0);
  LONGS_EQUAL(certain.filled, uncertain.filled);
  CHECK(uncertain.seen < certain.seen);
  CHECK(uncertain.seen > uncertain.filled);  // empty cells well inside the view still count
}

TEST(DemCoverage, ThePlanesUncertaintyGrowsBeyondItsPoints) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::vector<Vec3> pts;
  for (int i = 0; i < 40; ++i) {  // 4 m x 4 m at 8-12 m north
    const double n = 8.0 + 0.1 * i, e = -2.0 + 0.1 * ((i * 17) % 40);
    pts.emplace_back(n, e, 0.1 + 0.05 * n - 0.02 * e + noise(rng));
  }
  GroundPlane plane;
  CHECK(products::fitGroundPlane(pts, 0.0, plane));
  DOUBLES_EQUAL(0.05, plane.c(1), 0.01);
  DOUBLES_EQUAL(-0.02, plane.c(2), 0.01);
  DOUBLES_EQUAL(0.02, plane.sigma_m, 0.01);
  const double inside = plane.sigmaUp(10.0, 0.0), beyond = plane.sigmaUp(0.0, 0.0);
  DOUBLES_EQUAL(plane.sigma_m, inside, 0.2 * plane.sigma_m);
  CHECK(beyond > 1.5 * inside);
}
