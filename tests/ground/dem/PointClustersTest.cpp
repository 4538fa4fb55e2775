// Single-linkage cluster sizes (ground/dem/PointClusters) against a brute-force flood fill over all pairs,
// on random clouds with clumps, lattices (points exactly one link apart, on bucket edges), duplicates and a
// non-finite point; several seeds and link distances.
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include "ground/dem/PointClusters.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dem;

namespace {

std::vector<int32_t> bruteForce(const std::vector<double>& x, const std::vector<double>& y, double link_m) {
  const std::size_t n = x.size();
  std::vector<int> label(n, -1);
  std::vector<int32_t> size(n, 0);
  for (std::size_t s = 0; s < n; ++s) {
    if (label[s] >= 0) continue;
    std::vector<std::size_t> members{s}, stack{s};
    label[s] = static_cast<int>(s);
    while (!stack.empty()) {
      const std::size_t p = stack.back();
      stack.pop_back();
      for (std::size_t q = 0; q < n; ++q) {
        const double dx = x[p] - x[q], dy = y[p] - y[q];
        if (label[q] >= 0 || !(dx * dx + dy * dy <= link_m * link_m)) continue;
        label[q] = static_cast<int>(s);
        members.push_back(q);
        stack.push_back(q);
      }
    }
    for (std::size_t m : members) size[m] = static_cast<int32_t>(members.size());
  }
  return size;
}

}  // namespace

TEST_GROUP(PointClusters){};

TEST(PointClusters, SizesMatchBruteForce) {
  for (unsigned seed : {1u, 2u, 3u, 4u}) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-20.0, 20.0);
    std::normal_distribution<double> clump(0.0, 0.3);
    std::vector<double> x, y;
    for (int i = 0; i < 600; ++i) {  // sparse: many singletons and small clusters
      x.push_back(u(rng));
      y.push_back(u(rng));
    }
    for (int c = 0; c < 12; ++c) {  // clumps of 1 to 45 points
      const double cx = u(rng), cy = u(rng);
      for (int i = 0; i < 1 + 4 * c; ++i) {
        x.push_back(cx + clump(rng));
        y.push_back(cy + clump(rng));
      }
    }
    const double link = 0.4 + 0.3 * seed;
    for (int i = 0; i < 6; ++i) {  // a lattice exactly one link apart (linked: at most link)
      x.push_back(30.0 + i * link);
      y.push_back(-30.0);
    }
    x.push_back(x[5]);  // a duplicate
    y.push_back(y[5]);
    x.push_back(std::numeric_limits<double>::quiet_NaN());
    y.push_back(0.0);
    const std::vector<int32_t> got = clusterSizes(x, y, link), want = bruteForce(x, y, link);
    long long wrong = 0, largest = 0, singletons = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      wrong += got[i] != want[i];
      largest = std::max<long long>(largest, want[i]);
      singletons += want[i] == 1;
    }
    std::printf(
        "\n  seed %u, %zu points, link %.2f m: largest cluster %lld, %lld singletons, %lld sizes wrong", seed,
        x.size(), link, largest, singletons, wrong);
    CHECK_EQUAL(0, wrong);
    CHECK(largest >= 45 && singletons > 10);
    CHECK_EQUAL(1, got.back());  // the non-finite point
  }
  std::printf("\n");
}
