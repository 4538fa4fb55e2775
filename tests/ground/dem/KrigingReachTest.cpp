// The kriging's reach from each point's own spacing (KrigingOptions::local_reach): a cloud sampled as a
// camera 1.5 m above level ground samples it, one row of points per image row (4 mrad pixels, a 1-rad
// sector from 2 m to 16 m), so that the rows lie range^2 x 4 mrad / 1.5 m apart (1 cm at 2 m, 60 cm at
// 15 m); with a hole cut in it (a shadow, 3 m long at 11.5-14.5 m) and a lone point beyond it.
//  - With the points' own reaches the cells between the far rows are kriged (>= 95 % at 11-16 m outside the
//    hole); with one reach for the whole cloud (set by its dense near part) most of them are not.
//  - The hole's middle (cells farther than 1.2 m from every point: twice the reach of the rows around it)
//    stays empty, and so do the cells around the lone point (the support rule).
#include <cmath>
#include <cstdio>
#include <vector>

#include "ground/dem/Kriging.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dem;

namespace {

constexpr double kHeightM = 1.5, kPixelRad = 0.004;

bool inHole(double range, double azimuth) { return range >= 11.5 && range <= 14.5 && std::fabs(azimuth) <= 0.1; }

std::vector<DemPoint> cameraRows() {
  std::vector<DemPoint> pts;
  for (double dip = std::atan(kHeightM / 2.0); dip >= std::atan(kHeightM / 16.0); dip -= kPixelRad) {
    const double range = kHeightM / std::tan(dip);
    for (double az = -0.5; az <= 0.5; az += kPixelRad) {
      if (inHole(range, az)) continue;
      const double n = range * std::cos(az), e = range * std::sin(az);
      pts.push_back(DemPoint{n, e, 0.05 * std::sin(0.5 * n) + 0.03 * e, 0.005, -1});
    }
  }
  pts.push_back(DemPoint{20.0, 0.0, 0.0, 0.005, -1});  // a lone point beyond the rows
  return pts;
}

}  // namespace

TEST_GROUP(KrigingReach){};

TEST(KrigingReach, FarRowsBridgedHoleAndLonePointLeftEmpty) {
  const std::vector<DemPoint> pts = cameraRows();
  areomap::DemGrid grid;
  grid.cell_m = 0.05;
  grid.east0_m = -9.0;
  grid.north0_m = 21.0;
  grid.cols = 360;
  grid.rows = 420;
  KrigingOptions local, fixed;
  fixed.local_reach = false;
  const KrigingResult a = krigeDem(pts, grid, local), b = krigeDem(pts, grid, fixed);
  long long far = 0, far_local = 0, far_fixed = 0, hole_middle = 0, hole_filled = 0, lone = 0;
  for (int r = 0; r < grid.rows; ++r) {
    for (int c = 0; c < grid.cols; ++c) {
      const double n = grid.northOfRow(r), e = grid.eastOfCol(c);
      const double range = std::hypot(n, e), az = std::atan2(e, n);
      const bool ka = a.elevation.at(c, r) != a.elevation.nodata, kb = b.elevation.at(c, r) != b.elevation.nodata;
      if (std::hypot(n - 20.0, e) <= 1.0) lone += ka;
      if (range >= 11.0 && range <= 16.0 && std::fabs(az) <= 0.45 && !(range >= 11.0 && range <= 15.0 && std::fabs(az) <= 0.15)) {
        ++far;
        far_local += ka;
        far_fixed += kb;
      }
      if (!inHole(range, az)) continue;
      double nearest = 1e9;
      for (const DemPoint& p : pts) nearest = std::min(nearest, std::hypot(p.north_m - n, p.east_m - e));
      if (nearest <= 1.2) continue;
      ++hole_middle;
      hole_filled += ka;
    }
  }
  std::printf("\n  gap %.3f m, largest reach %.3f m; 11-16 m: %lld cells, %.1f %% kriged with the points' reaches, %.1f %% "
              "with one; hole middle %lld cells, %lld kriged; lone point %lld\n",
              a.max_gap_m, a.max_local_gap_m, far, 100.0 * far_local / far, 100.0 * far_fixed / far, hole_middle,
              hole_filled, lone);
  CHECK(far > 1000);
  CHECK(far_local >= 0.95 * far);
  CHECK(far_fixed < 0.6 * far);  // the premise: one reach for the cloud leaves the far rows apart
  CHECK(hole_middle > 50);
  CHECK_EQUAL(0, hole_filled);
  CHECK_EQUAL(0, lone);
  DOUBLES_EQUAL(a.max_gap_m, b.max_gap_m, 0.0);
  CHECK(a.max_local_gap_m > a.max_gap_m);
}
