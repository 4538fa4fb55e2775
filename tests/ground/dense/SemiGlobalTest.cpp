#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include <opencv2/core.hpp>

#include "ground/dense/SemiGlobal.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dense;

namespace {

// Hirschmüller's recursion written out per direction and disparity, independently of the aggregation's
// layout: L(p, d) = C(p, d) + min(L(q, d), L(q, d +- 1) + P1, min L(q) + P2') - min L(q), q = p + (dy, dx)
// the predecessor, L(q, d) infinite outside q's band, L(p, d) = C(p, d) where q lies outside the image.
std::vector<uint16_t> referenceSum(const BandVolume& v, const cv::Mat& guide, const SemiGlobalParams& prm) {
  const int dirs[8][2] = {{0, -1}, {-1, 0}, {0, 1}, {1, 0}, {-1, -1}, {-1, 1}, {1, 1}, {1, -1}};
  const int inf = std::numeric_limits<int>::max() / 4;
  std::vector<uint16_t> sum(v.cost.size(), 0);
  for (int r = 0; r < (prm.paths >= 8 ? 8 : 4); ++r) {
    const int dy = dirs[r][0], dx = dirs[r][1];
    std::vector<std::vector<int>> path(static_cast<std::size_t>(v.rows * v.cols));
    for (int iy = 0; iy < v.rows; ++iy) {
      const int y = dy > 0 ? v.rows - 1 - iy : iy;
      for (int ix = 0; ix < v.cols; ++ix) {
        const int x = dx > 0 ? v.cols - 1 - ix : ix;
        const std::size_t p = static_cast<std::size_t>(y * v.cols + x);
        const int qy = y + dy, qx = x + dx;
        const bool start = qy < 0 || qy >= v.rows || qx < 0 || qx >= v.cols;
        const std::size_t q = start ? 0 : static_cast<std::size_t>(qy * v.cols + qx);
        const auto prev = [&](int d) {
          const int j = d - v.lo[q];
          return j >= 0 && j < v.count[q] ? path[q][static_cast<std::size_t>(j)] : inf;
        };
        int qmin = inf, p2 = 0;
        if (!start) {
          qmin = *std::min_element(path[q].begin(), path[q].end());
          const int di = std::abs(guide.at<uint8_t>(y, x) - guide.at<uint8_t>(qy, qx));
          p2 = std::max(prm.p1 + 1, prm.p2 * 16 / (16 + di));
        }
        for (int j = 0; j < v.count[p]; ++j) {
          const int d = v.lo[p] + j, c = v.cost[static_cast<std::size_t>(v.offset[p] + j)];
          const int l =
              start ? c
                    : c + std::min({prev(d), prev(d - 1) + prm.p1, prev(d + 1) + prm.p1, qmin + p2}) - qmin;
          path[p].push_back(l);
          uint16_t& s = sum[static_cast<std::size_t>(v.offset[p] + j)];
          s = static_cast<uint16_t>(s + l);
        }
      }
    }
  }
  return sum;
}

// A banded volume with random bands: neighbours' bands mostly a few disparities apart, now and then far
// apart (no shared disparity), lengths 1..max_count, costs 0..max_cost.
BandVolume randomVolume(std::mt19937& rng, int rows, int cols, int max_count, int max_cost) {
  BandVolume v;
  v.rows = rows;
  v.cols = cols;
  std::uniform_int_distribution<int> count(1, max_count), shift(-3, 3), far(0, 9), cost(0, max_cost);
  int lo = 40;
  for (int i = 0; i < rows * cols; ++i) {
    lo = far(rng) == 0 ? 20 + 10 * shift(rng) + 30 : std::max(0, lo + shift(rng));
    v.lo.push_back(lo);
    v.count.push_back(count(rng));
  }
  v.finishLayout();
  for (uint16_t& c : v.cost) c = static_cast<uint16_t>(cost(rng));
  return v;
}

cv::Mat randomGuide(int rows, int cols) {
  cv::Mat g(rows, cols, CV_8UC1);
  cv::randu(g, 0, 256);
  return g;
}

}  // namespace

TEST_GROUP(SemiGlobal){};

TEST(SemiGlobal, EqualsTheRecursionWrittenOut) {
  std::mt19937 rng(7);
  struct Case {
    int rows, cols, max_count, max_cost;
    SemiGlobalParams prm;
  };
  const Case cases[] = {{17, 23, 6, 62, {8, 96, 8}},   // the fine pass's bands and costs
                        {13, 19, 40, 62, {8, 64, 4}},  // wide bands over several lane groups, 4 paths
                        {9, 11, 19, kMaxSemiGlobalCost, {kMaxSemiGlobalPenalty, kMaxSemiGlobalPenalty, 8}}};
  for (const Case& c : cases) {
    const BandVolume v = randomVolume(rng, c.rows, c.cols, c.max_count, c.max_cost);
    const cv::Mat guide = randomGuide(c.rows, c.cols);
    std::vector<uint16_t> sum;
    aggregateSemiGlobal(v, guide, c.prm, sum);
    const std::vector<uint16_t> want = referenceSum(v, guide, c.prm);
    CHECK_EQUAL(want.size(), sum.size());
    long long differ = 0;
    for (std::size_t i = 0; i < want.size(); ++i) differ += want[i] != sum[i];
    LONGS_EQUAL(0, differ);
  }
}

TEST(SemiGlobal, RefusesCostsAndPenaltiesBeyondItsLanes) {
  std::mt19937 rng(3);
  BandVolume v = randomVolume(rng, 5, 6, 4, 62);
  const cv::Mat guide = randomGuide(5, 6);
  std::vector<uint16_t> sum;
  CHECK_THROWS(std::invalid_argument, aggregateSemiGlobal(v, guide, {8, kMaxSemiGlobalPenalty + 1, 8}, sum));
  v.cost[3] = kMaxSemiGlobalCost + 1;
  CHECK_THROWS(std::invalid_argument, aggregateSemiGlobal(v, guide, {8, 96, 8}, sum));
}
