#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <stdexcept>
#include <tuple>
#include <vector>

#include "ground/dem/BinnedCloud.hpp"
#include "ground/dem/PackedCloud.hpp"
#include "ground/dense/LineId.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using namespace areomap::dem;

namespace {

const Vec3 kCloudOrigin(3.25, -7.5, -1.4);  // site frame, Z down

// `per_pair` points of each of `pairs` pairs (ids 0, 1, 5, ...: not consecutive), scattered over a
// 12 m x 12 m square about the gimbal centre with heights and sigmas of a few centimetres; rows of the
// rectified image up to the largest a line holds.
std::vector<DemPoint> packedTestPoints(int pairs, int per_pair, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> across(-6.0, 6.0), height(-0.3, 0.3), sigma(0.005, 0.05);
  std::uniform_int_distribution<int64_t> row(0, dense::kLineRowsPerPair - 1);
  std::vector<DemPoint> out;
  for (int k = 0; k < pairs; ++k) {
    const int64_t pair_id = k * k + (k > 1 ? 1 : 0);
    for (int i = 0; i < per_pair; ++i) {
      DemPoint p;
      p.north_m = kCloudOrigin.x() + across(rng);
      p.east_m = kCloudOrigin.y() + across(rng);
      p.elevation_m = -kCloudOrigin.z() - 1.4 + height(rng);
      p.sigma_m = sigma(rng);
      p.line = dense::lineId(pair_id, row(rng));
      out.push_back(p);
    }
  }
  return out;
}

PackedCloud packedCloudOf(const std::vector<DemPoint>& pts) {
  PackedCloud cloud(kCloudOrigin);
  for (const DemPoint& p : pts) cloud.push(p);
  return cloud;
}

// A float offset from the origin is within half a float ulp of the offset: 2^-24 of it.
void checkWithinFloat(double expected, double origin, double got) {
  const double offset = std::fabs(expected - origin);
  CHECK(std::fabs(got - expected) <= std::ldexp(offset, -24) + 1e-15);
}

}  // namespace

TEST_GROUP(PackedCloud){};

// Every point pushed comes back: its line exact (any pair id and row, -1 included), its position within
// float rounding of its offset from the gimbal centre, its sigma the float of it.
TEST(PackedCloud, EveryPointComesBackWithItsLine) {
  std::vector<DemPoint> pts = packedTestPoints(4, 500, 7);
  DemPoint unlined = pts.back();
  unlined.line = -1;
  pts.push_back(unlined);
  DemPoint last_row = pts.front();
  last_row.line = dense::lineId(40000, dense::kLineRowsPerPair - 1);
  pts.push_back(last_row);
  const PackedCloud cloud = packedCloudOf(pts);
  CHECK_EQUAL(pts.size(), cloud.size());
  CHECK_EQUAL(6u, cloud.runs().size());  // four pairs, the unlined point, the far pair
  std::size_t counted = 0;
  cloud.forEach([&](std::size_t i, const DemPoint& p) {
    CHECK_EQUAL(counted, i);
    ++counted;
    const DemPoint& q = pts[i];
    CHECK_EQUAL(q.line, p.line);
    checkWithinFloat(q.north_m, kCloudOrigin.x(), p.north_m);
    checkWithinFloat(q.east_m, kCloudOrigin.y(), p.east_m);
    checkWithinFloat(q.elevation_m, -kCloudOrigin.z(), p.elevation_m);
    CHECK_EQUAL(static_cast<double>(static_cast<float>(q.sigma_m)), p.sigma_m);
    CHECK_EQUAL(p.line, cloud.at(i).line);
  });
  CHECK_EQUAL(pts.size(), counted);
  CHECK_THROWS(std::out_of_range, cloud.at(pts.size()));
}

// keepIf keeps the accepted points in order, tells where each went and drops the runs it empties.
TEST(PackedCloud, KeepIfMovesThePointsItKeeps) {
  const std::vector<DemPoint> pts = packedTestPoints(3, 100, 11);
  PackedCloud cloud = packedCloudOf(pts);
  std::vector<std::size_t> from(pts.size(), pts.size());
  cloud.keepIf([](std::size_t i, const DemPoint&) { return i % 3 == 0 && (i < 100 || i >= 200); },
               [&](std::size_t f, std::size_t t) { from[t] = f; });
  CHECK_EQUAL(67u, cloud.size());  // 34 of the first pair, 33 of the third
  CHECK_EQUAL(2u, cloud.runs().size());
  cloud.forEach([&](std::size_t i, const DemPoint& p) {
    CHECK_EQUAL(pts[from[i]].line, p.line);
    checkWithinFloat(pts[from[i]].north_m, kCloudOrigin.x(), p.north_m);
  });
}

TEST(PackedCloud, AppendKeepsOneOrigin) {
  const std::vector<DemPoint> pts = packedTestPoints(2, 50, 3);
  PackedCloud a = packedCloudOf(pts);
  const PackedCloud b = packedCloudOf(pts);
  a.append(b);
  CHECK_EQUAL(2 * pts.size(), a.size());
  CHECK_EQUAL(4u, a.runs().size());  // pairs 0 and 1, then both again
  CHECK_EQUAL(pts[7].line, a.at(pts.size() + 7).line);
  PackedCloud elsewhere(Vec3(0.0, 0.0, 0.0));
  elsewhere.push(pts[0]);
  CHECK_THROWS(std::invalid_argument, a.append(elsewhere));
  a.release();
  CHECK_EQUAL(0u, a.size());
}

TEST_GROUP(BinnedCloud){};

// Every point reaches the bins, and each cell's mean is the one summed directly: per pair slot the
// points in the cloud's order, then the slots in increasing order (as binPoints sums them, whatever
// band of rows a cell falls in): bit for bit.
namespace {

// binPoints of `cloud` over the test square against the sums made directly (the test below).
void checkDirectSums(const PackedCloud& cloud) {
  DemGrid grid;  // over the whole square
  grid.cell_m = 0.25;
  grid.north0_m = kCloudOrigin.x() + 6.5;
  grid.east0_m = kCloudOrigin.y() - 6.5;
  grid.rows = grid.cols = 52;
  // Some points refused, to check the count of those binned.
  const auto keep = [](const DemPoint& p) { return p.sigma_m < 0.045; };
  const BinnedCloud binned = binPoints(cloud, grid, keep, 1.5);
  struct Sums {
    double n = 0, x = 0, y = 0, z = 0;
  };
  std::map<std::tuple<long long, long long>, std::map<long long, Sums>> cells;  // (row, col) -> slot -> sums
  long long accepted = 0;
  cloud.forEach([&](std::size_t, const DemPoint& p) {
    if (!keep(p)) return;
    ++accepted;
    const long long r = static_cast<long long>(std::floor((grid.north0_m - p.north_m) / grid.cell_m));
    const long long c = static_cast<long long>(std::floor((p.east_m - grid.east0_m) / grid.cell_m));
    Sums& s = cells[{r, c}][dense::linePair(p.line) + 1];
    s.n += 1;
    s.x += p.north_m;
    s.y += p.east_m;
    s.z += p.elevation_m;
  });
  CHECK_EQUAL(accepted, binned.binned_points);
  CHECK(accepted < static_cast<long long>(cloud.size()));
  CHECK_EQUAL(cells.size(), binned.points.size());
  std::map<std::tuple<double, double>, double> mean_height;  // (north, east) -> height
  for (const auto& cell : cells) {
    Sums all;
    for (const auto& slot : cell.second) {
      all.n += slot.second.n;
      all.x += slot.second.x;
      all.y += slot.second.y;
      all.z += slot.second.z;
    }
    mean_height[{all.x / all.n, all.y / all.n}] = all.z / all.n;
  }
  for (const DemPoint& p : binned.points) {
    const auto it = mean_height.find({p.north_m, p.east_m});
    CHECK(it != mean_height.end());
    if (it != mean_height.end()) CHECK_EQUAL(it->second, p.elevation_m);
  }
}

}  // namespace

TEST(BinnedCloud, EveryPointIsBinnedAndEachCellMeanIsTheDirectSum) {
  checkDirectSums(packedCloudOf(packedTestPoints(5, 4000, 5)));
}

// The same with each pair's points in the order of their north coordinate, as neighbouring pixels of an
// image row lie on neighbouring ground: most blocks of the cloud's points then hold the rows of one band
// of the sums, and the bands pass over the others without reading them.
TEST(BinnedCloud, PointsInGroundOrderAreEachBinnedOnce) {
  std::vector<DemPoint> pts = packedTestPoints(5, 4000, 6);
  for (std::size_t first = 0; first < pts.size(); first += 4000) {
    std::sort(pts.begin() + static_cast<std::ptrdiff_t>(first),
              pts.begin() + static_cast<std::ptrdiff_t>(first + 4000),
              [](const DemPoint& a, const DemPoint& b) { return a.north_m > b.north_m; });
  }
  checkDirectSums(packedCloudOf(pts));
}
