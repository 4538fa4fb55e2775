// The horizon over a window of the grid (ground/dem/Viewshed.hpp) against the whole grid's at the same
// cells, bit for bit: rough terrain with nodata holes, eyes inside, at the edge of and outside the grid,
// windows about, beside and away from the eye, both interpolation rules; and forEachHorizon's horizons in
// the eyes' order on several threads.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "ground/cli/Parallel.hpp"
#include "ground/dem/Viewshed.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using namespace areomap::dem;

namespace {

DemGrid viewshedTerrain() {
  DemGrid g;
  g.cell_m = 0.1;
  g.north0_m = 6.0;
  g.east0_m = -7.0;
  g.cols = 130;
  g.rows = 110;
  g.values.resize(static_cast<std::size_t>(g.cols) * g.rows);
  uint32_t state = 12345u;
  for (int r = 0; r < g.rows; ++r) {
    for (int c = 0; c < g.cols; ++c) {
      state = state * 1664525u + 1013904223u;
      const double n = g.northOfRow(r), e = g.eastOfCol(c);
      double z = 0.3 * std::sin(0.9 * n) * std::cos(0.7 * e) + 0.02 * ((state >> 8) % 100) / 100.0;
      if (std::hypot(n - 2.0, e + 1.0) < 0.4) z += 0.8;  // a rock that casts a shadow
      g.at(c, r) = ((state >> 20) % 37 == 0) ? g.nodata : static_cast<float>(z);
    }
  }
  return g;
}

bool viewshedSameBits(float a, float b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

// Every cell of `w` inside the grid equals the whole grid's horizon there; cells beyond it are -infinity.
int viewshedWindowMismatches(const DemGrid& g, const Vec3& eye, const GridWindow& w, bool widen) {
  std::vector<float> whole, part;
  horizonFrom(g, eye, whole, widen);
  horizonFrom(g, eye, w, part, widen);
  if (part.size() != static_cast<std::size_t>(w.cols) * w.rows) return -1;
  int bad = 0;
  for (int r = w.row0; r < w.row0 + w.rows; ++r) {
    for (int c = w.col0; c < w.col0 + w.cols; ++c) {
      const bool inside = c >= 0 && r >= 0 && c < g.cols && r < g.rows;
      const float expected =
          inside ? whole[static_cast<std::size_t>(r) * g.cols + c] : -std::numeric_limits<float>::infinity();
      bad += !viewshedSameBits(part[w.at(c, r)], expected);
    }
  }
  return bad;
}

}  // namespace

TEST_GROUP(Viewshed){};

TEST(Viewshed, WindowEqualsWholeGrid) {
  const DemGrid g = viewshedTerrain();
  const Vec3 eyes[] = {Vec3(0.0, 0.0, -1.5), Vec3(5.9, -6.9, -1.2), Vec3(-8.0, 9.0, -2.0),
                       Vec3(1.03, 2.47, -0.9)};
  const GridWindow windows[] = {
      {0, 0, g.cols, g.rows}, {40, 30, 50, 40}, {100, 5, 40, 20}, {-5, 90, 30, 30}, {3, 3, 1, 1}};
  int checked = 0, shadowed = 0;
  for (const Vec3& eye : eyes) {
    std::vector<float> whole;
    horizonFrom(g, eye, whole, false);
    for (std::size_t i = 0; i < whole.size(); ++i)
      shadowed += g.values[i] != g.nodata && g.values[i] < whole[i];
    for (const GridWindow& w : windows) {
      for (bool widen : {false, true}) {
        LONGS_EQUAL(0, viewshedWindowMismatches(g, eye, w, widen));
        ++checked;
      }
    }
  }
  LONGS_EQUAL(40, checked);
  CHECK(shadowed > 100);  // the horizons are not trivially -infinity
}

TEST(Viewshed, EachHorizonInOrderOnThreads) {
  const DemGrid g = viewshedTerrain();
  const std::vector<Vec3> eyes = {Vec3(0.0, 0.0, -1.5), Vec3(1.0, -2.0, -1.4), Vec3(-3.0, 2.0, -1.6),
                                  Vec3(2.5, 3.5, -1.3), Vec3(-1.0, -4.0, -1.5)};
  const std::vector<GridWindow> windows = {
      {20, 10, 70, 60}, {0, 0, g.cols, g.rows}, {5, 50, 30, 10}, {0, 0, 0, 0}, {60, 0, 70, 110}};
  cli::setThreads(3);
  std::vector<std::size_t> order;
  int bad = 0;
  forEachHorizon(g, eyes, windows, true, [&](std::size_t k, const std::vector<float>& horizon) {
    order.push_back(k);
    std::vector<float> one;
    horizonFrom(g, eyes[k], windows[k], one, true);
    bad += one.size() != horizon.size() ||
           std::memcmp(one.data(), horizon.data(), one.size() * sizeof(float)) != 0;
  });
  cli::setThreads(0);
  LONGS_EQUAL(eyes.size(), order.size());
  for (std::size_t k = 0; k < order.size(); ++k) LONGS_EQUAL(k, order[k]);
  LONGS_EQUAL(0, bad);
}
