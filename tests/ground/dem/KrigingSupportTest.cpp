// The kriging's support rule (KrigingOptions::min_cluster_points): a continuous cloud (random points in a
// 10 m disc) plus, beyond its edge, lone points and clumps of 2, 5, 15, 16 and 40 points, each farther than
// the gap from everything else. With the rule (default: clusters of at least k = 16 points support cells)
// every cell is checked against a brute-force expectation: it is kriged exactly when a point within the gap
// belongs to a cluster of 16 or more (the clusters are known by construction). Without the rule
// (min_cluster_points = 1) the lone points and small clumps are kriged into discs; the cells of the
// continuous part and of the large clumps are the same cells, with bit-identical values and sigmas, either
// way. Three seeds, densities and cell sizes.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "ground/dem/Kriging.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dem;

namespace {

double surface(double n, double e) {
  return 0.3 * std::sin(0.4 * n) * std::cos(0.3 * e) + 0.05 * n;
}

struct Scene {
  std::vector<DemPoint> points;
  std::vector<int> cluster;       // per point: 0 the continuous part, else the clump's number
  std::vector<int> cluster_size;  // per cluster
};

struct Variant {
  unsigned seed;
  int continuous_points;
  double cell_m;
};

constexpr int kClumpSizes[] = {1, 1, 1, 1, 1, 1, 1, 1, 2, 2, 5, 15, 16, 40};

// Clump centres at 12.5-15.5 m, spread within 0.3 m; `separation_m` (more than twice the gap: an island's
// cells are then within the gap of its own points only) between clumps, rejection-sampled.
Scene makeScene(const Variant& v, double separation_m) {
  std::mt19937 rng(v.seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.01);
  Scene s;
  s.cluster_size.push_back(v.continuous_points);
  const auto add = [&](double n, double e, int cluster) {
    s.points.push_back(DemPoint{n, e, surface(n, e) + noise(rng), 0.01, -1});
    s.cluster.push_back(cluster);
  };
  for (int i = 0; i < v.continuous_points; ++i) {
    const double r = 10.0 * std::sqrt(u(rng)), a = 2 * M_PI * u(rng);
    add(r * std::cos(a), r * std::sin(a), 0);
  }
  std::vector<std::pair<double, double>> centres;
  for (int size : kClumpSizes) {
    double cn = 0, ce = 0;
    bool ok = false;
    for (int attempt = 0; attempt < 10000 && !ok; ++attempt) {
      const double r = 12.5 + 3.0 * u(rng), a = 2 * M_PI * u(rng);
      cn = r * std::cos(a);
      ce = r * std::sin(a);
      ok = true;
      for (const auto& c : centres) ok &= std::hypot(c.first - cn, c.second - ce) > separation_m;
    }
    if (!ok) return Scene{};  // no room (the test checks for it)
    centres.emplace_back(cn, ce);
    const int id = static_cast<int>(s.cluster_size.size());
    s.cluster_size.push_back(size);
    for (int i = 0; i < size; ++i) {
      const double r = i == 0 ? 0.0 : 0.3 * std::sqrt(u(rng)), a = 2 * M_PI * u(rng);
      add(cn + r * std::cos(a), ce + r * std::sin(a), id);
    }
  }
  return s;
}

areomap::DemGrid gridFor(double cell_m) {
  areomap::DemGrid g;
  g.cell_m = cell_m;
  g.cols = g.rows = static_cast<int>(std::ceil(33.0 / cell_m));
  g.east0_m = -0.5 * g.cols * cell_m;
  g.north0_m = 0.5 * g.rows * cell_m;
  return g;
}

}  // namespace

TEST_GROUP(KrigingSupport){};

TEST(KrigingSupport, LonePointsAndSmallClumpsStayEmptyTheRestIsUnchanged) {
  const Variant variants[] = {{1, 4000, 0.25}, {2, 6000, 0.2}, {3, 2500, 0.3}};
  for (const Variant& v : variants) {
    const Scene s = makeScene(v, 4.5);
    CHECK(!s.points.empty());
    const areomap::DemGrid grid = gridFor(v.cell_m);
    // One reach for every point (the cloud's gap): the rule is checked against it cell by cell (the points'
    // own reaches, KrigingOptions::local_reach, are KrigingReach's).
    KrigingOptions with;
    with.local_reach = false;
    KrigingOptions without = with;
    without.min_cluster_points = 1;
    const KrigingResult rule = krigeDem(s.points, grid, with);
    const KrigingResult old = krigeDem(s.points, grid, without);
    const double gap = rule.max_gap_m;
    CHECK_EQUAL(16, rule.min_cluster_points);
    DOUBLES_EQUAL(gap, old.max_gap_m, 0.0);
    // The scene's premise: every clump lies farther than the gap from the points of every other cluster.
    long long small_points = 0, too_close = 0;
    for (std::size_t i = 0; i < s.points.size(); ++i) {
      if (s.cluster[i] == 0) continue;
      small_points += s.cluster_size[static_cast<std::size_t>(s.cluster[i])] < 16;
      for (std::size_t j = 0; j < s.points.size(); ++j) {
        const DemPoint &a = s.points[i], &b = s.points[j];
        too_close +=
            s.cluster[j] != s.cluster[i] && std::hypot(a.north_m - b.north_m, a.east_m - b.east_m) <= gap;
      }
    }
    CHECK_EQUAL(0, too_close);
    CHECK_EQUAL(small_points, rule.isolated_points);
    long long expected_empty = 0, island_cells_old = 0, kept_cells = 0, mismatches = 0, changed = 0;
    for (int r = 0; r < grid.rows; ++r) {
      for (int c = 0; c < grid.cols; ++c) {
        const double n = grid.northOfRow(r), e = grid.eastOfCol(c);
        bool near_any = false, near_large = false;
        for (std::size_t i = 0; i < s.points.size(); ++i) {
          if (std::hypot(s.points[i].north_m - n, s.points[i].east_m - e) > gap) continue;
          near_any = true;
          near_large |= s.cluster_size[static_cast<std::size_t>(s.cluster[i])] >= 16;
        }
        const bool kriged = rule.elevation.at(c, r) != rule.elevation.nodata;
        const bool kriged_old = old.elevation.at(c, r) != old.elevation.nodata;
        mismatches += kriged != near_large;
        expected_empty += near_any && !near_large;
        island_cells_old += kriged_old && !near_large;
        if (kriged) {
          ++kept_cells;
          changed +=
              rule.elevation.at(c, r) != old.elevation.at(c, r) || rule.sigma.at(c, r) != old.sigma.at(c, r);
        }
      }
    }
    std::printf(
        "\n  seed %u, %d + %lld points, cell %.2f m, gap %.3f m: %lld cells kriged, %lld left empty by the "
        "rule "
        "(expected %lld; without it %lld island cells), %lld cells off the expectation, %lld changed",
        v.seed, v.continuous_points, static_cast<long long>(s.points.size()) - v.continuous_points, v.cell_m,
        gap, kept_cells, rule.cells_unsupported, expected_empty, island_cells_old, mismatches, changed);
    CHECK_EQUAL(0, mismatches);
    CHECK_EQUAL(expected_empty, rule.cells_unsupported);
    CHECK_EQUAL(expected_empty, island_cells_old);  // without the rule, every one of them is a disc cell
    CHECK(island_cells_old > 100);
    CHECK_EQUAL(kept_cells + expected_empty, old.cells_kriged);
    CHECK_EQUAL(0, changed);
  }
  std::printf("\n");
}
