// The traverse map's nearest-site mosaic (ground/traverse/TraverseMosaic.hpp) on two sites whose rasters
// sample one analytic surface, each in its own site frame (a turned and raised frame for the second): the
// mosaic equals the surface in the traverse frame to the bilinear interpolation's error, each cell comes
// from the nearer site that has data, a site's nodata hole is filled from the other, and the sigma takes
// the site's extra variance.
#include <cmath>
#include <cstdio>
#include <vector>

#include "ground/traverse/TraverseMosaic.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using namespace areomap::traverse;

namespace {

// Elevation up of the surface at a traverse-frame position (north, east).
double surface(double north, double east) {
  return 0.3 * std::sin(0.2 * north) + 0.1 * std::cos(0.3 * east);
}

// The raster of `pose`'s site: its cells' elevation (up, site frame) of the surface, 10 x 10 m at 5 cm.
DemGrid siteRaster(const SitePose& pose) {
  DemGrid g;
  g.cell_m = 0.05;
  g.cols = g.rows = 200;
  g.east0_m = -5.0;
  g.north0_m = 5.0;
  g.values.resize(static_cast<std::size_t>(g.cols) * g.rows);
  for (int r = 0; r < g.rows; ++r) {
    for (int c = 0; c < g.cols; ++c) {
      const Eigen::Vector3d t = pose.toTraverse(Eigen::Vector3d(g.northOfRow(r), g.eastOfCol(c), 0.0));
      // up in the site frame = up in the traverse frame + position.z (Z down).
      g.at(c, r) = static_cast<float>(surface(t.x(), t.y()) + pose.position_m.z());
    }
  }
  return g;
}

}  // namespace

TEST_GROUP(TraverseMosaic){};

TEST(TraverseMosaic, NearestSiteOfOneSurface) {
  SitePose a, b;
  b.position_m = Eigen::Vector3d(6.0, 2.0, -0.4);
  b.heading_rad = 0.5;
  DemGrid ra = siteRaster(a), rb = siteRaster(b);
  // A hole in the first site's raster near the second site: filled from the second.
  for (int r = 20; r < 40; ++r)
    for (int c = 150; c < 170; ++c) ra.at(c, r) = ra.nodata;
  const std::vector<MosaicInput> in{{a, &ra, 0.0}, {b, &rb, 0.0}};
  const DemGrid grid = traverseGrid(in, 0.05);
  const Mosaic m = mosaic(in, grid, MosaicKind::kElevation);
  double worst = 0.0, sum2 = 0.0;
  int cells = 0, wrong_site = 0;
  for (int r = 0; r < grid.rows; ++r) {
    for (int c = 0; c < grid.cols; ++c) {
      const float v = m.grid.at(c, r);
      if (v == m.grid.nodata) continue;
      const double n = grid.northOfRow(r), e = grid.eastOfCol(c);
      worst = std::max(worst, std::fabs(v - surface(n, e)));
      sum2 += (v - surface(n, e)) * (v - surface(n, e));
      ++cells;
      const int site = m.site_of_cell[static_cast<std::size_t>(r) * grid.cols + c];
      const bool b_nearer = std::hypot(n - 6.0, e - 2.0) < std::hypot(n, e);
      // Inside both footprints (away from their edges and the hole) the nearer site must have given it.
      const Eigen::Vector3d sb = b.toSite(Eigen::Vector3d(n, e, 0.0));
      const bool in_both = std::fabs(n) < 4.5 && std::fabs(e) < 4.5 && std::fabs(sb.x()) < 4.5 &&
                           std::fabs(sb.y()) < 4.5 && !(n > 2.9 && n < 4.1 && e > 2.4 && e < 3.6);
      if (in_both && site != (b_nearer ? 1 : 0)) ++wrong_site;
    }
  }
  const double rms = std::sqrt(sum2 / cells);
  std::printf("\n  %d cells, error against the surface: RMS %.2e m, largest %.2e m; %d from the wrong site\n",
              cells, rms, worst, wrong_site);
  CHECK_TRUE(cells > 50000);
  // Bilinear inside a raster (h^2 / 8 |f''| ~ 4e-6 m); its outermost half cell takes the nearest cell, at
  // most half a cell's diagonal (3.5 cm) times the slope (<= 0.067): 2.4 mm.
  CHECK_TRUE(rms < 2e-4);
  CHECK_TRUE(worst < 2.5e-3);
  CHECK_EQUAL(0, wrong_site);
  // Against the surface rasterised at 10 cm in the traverse frame, within 4 m of either site: the same to
  // the truth raster's own interpolation; a pose 5 cm off shows.
  const SitePose identity;
  DemGrid truth = siteRaster(identity);
  truth.cell_m = 0.1;
  truth.cols = truth.rows = 200;
  truth.east0_m = -10.0;
  truth.north0_m = 10.0;
  truth.values.resize(40000);
  for (int r = 0; r < truth.rows; ++r)
    for (int c = 0; c < truth.cols; ++c)
      truth.at(c, r) = static_cast<float>(surface(truth.northOfRow(r), truth.eastOfCol(c)));
  const RasterDifference same = differenceNear(m.grid, truth, {a.position_m, b.position_m}, 4.0);
  SitePose off = b;
  off.position_m.z() += 0.05;
  const Mosaic shifted = mosaic({{a, &ra, 0.0}, {off, &rb, 0.0}}, grid, MosaicKind::kElevation);
  const RasterDifference moved = differenceNear(shifted.grid, truth, {a.position_m, b.position_m}, 4.0);
  std::printf("  against truth within 4 m: RMS %.2e m (%lld cells); second site 5 cm low: %.3f m\n",
              same.rms_m, same.cells, moved.rms_m);
  CHECK_TRUE(same.cells > 20000);
  CHECK_TRUE(same.rms_m < 1e-3);
  CHECK_TRUE(moved.rms_m > 0.02);
  // The hole (site a's, nearer to a there) is filled from b.
  const int hr = static_cast<int>((grid.north0_m - 3.5) / 0.05),
            hc = static_cast<int>((3.0 - grid.east0_m) / 0.05);
  CHECK_EQUAL(1, m.site_of_cell[static_cast<std::size_t>(hr) * grid.cols + hc]);
}

TEST(TraverseMosaic, SigmaTakesTheSiteVariance) {
  SitePose a;
  DemGrid s;
  s.cell_m = 0.1;
  s.cols = s.rows = 10;
  s.east0_m = -0.5;
  s.north0_m = 0.5;
  s.values.assign(100, 0.003f);
  const std::vector<MosaicInput> in{{a, &s, 0.004 * 0.004}};
  const Mosaic m = mosaic(in, traverseGrid(in, 0.1), MosaicKind::kSigma);
  DOUBLES_EQUAL(0.005, m.grid.at(5, 5), 1e-6);
}
