// The cameras' shared error in the DEM sigma (ground/dem/SharedHeightError.hpp, KrigingOptions::
// shared_error): a cell's variance gains exactly (sum_p W_p g_p)^T C (sum_p W_p g_p), W_p the kriging
// weight its pair's points carry (the weights sum to 1). Checked on a plane seen by two "pairs" (the west
// half by pair 3, the east half by pair 8, a strip between by both): where one pair alone supports a cell
// the added variance is g^T C_pp g whatever the weights; where both do and their errors are fully
// correlated and equal it is the same; with independent errors it is less (averaged by W_p^2).
#include <cmath>
#include <cstdio>
#include <vector>

#include "ground/dem/Kriging.hpp"
#include "ground/dem/SharedHeightError.hpp"
#include "ground/dense/LineId.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dem;

namespace {

constexpr double kStrip = 0.1;  // the east-west strip both pairs see (metres either side of east = 0)

struct Cloud {
  std::vector<DemPoint> points;
  std::vector<PointPairs> pairs;
};

Cloud planeOfTwoPairs() {
  Cloud c;
  for (int y = 0; y < 60; ++y) {
    for (int x = -40; x < 40; ++x) {
      DemPoint p;
      p.north_m = 0.02 * y;
      p.east_m = 0.02 * x + 0.01;
      p.elevation_m = 0.1 * p.north_m - 0.05 * p.east_m;
      p.sigma_m = 0.002;
      PointPairs pp;
      if (p.east_m < -kStrip) {
        pp.pair[0] = 3;
        pp.fraction[0] = 1.f;
      } else if (p.east_m > kStrip) {
        pp.pair[0] = 8;
        pp.fraction[0] = 1.f;
      } else {
        pp.pair[0] = 3;
        pp.pair[1] = 8;
        pp.fraction[0] = pp.fraction[1] = 0.5f;
      }
      p.line = areomap::dense::lineId(pp.pair[0], 0);
      c.points.push_back(p);
      c.pairs.push_back(pp);
    }
  }
  return c;
}

// A shared error whose only non-zero gradient is the first unknown of each block (g = 1 there, m / unit).
SharedHeightError oneDimensional(double var3, double var8, double cov) {
  SharedHeightError s;
  s.block_of_pair[3] = 0;
  s.block_of_pair[8] = 1;
  s.covariance = Eigen::MatrixXd::Zero(2 * kSharedErrorDims, 2 * kSharedErrorDims);
  s.covariance(0, 0) = var3;
  s.covariance(kSharedErrorDims, kSharedErrorDims) = var8;
  s.covariance(0, kSharedErrorDims) = s.covariance(kSharedErrorDims, 0) = cov;
  s.gradient = [](int, double, double, double, double* g) {
    for (int d = 0; d < kSharedErrorDims; ++d) g[d] = d == 0 ? 1.0 : 0.0;
    return true;
  };
  return s;
}

// The largest relative departure of the added variance from `expected(east)` over the kriged cells of
// the given region (east < -1.5 kStrip: west only; |east| < 0.5 kStrip: the strip).
double largestDeparture(const KrigingResult& with, const KrigingResult& without, bool strip,
                        double expected) {
  double worst = 0.0;
  int cells = 0;
  for (int r = 0; r < with.sigma.rows; ++r) {
    for (int c = 0; c < with.sigma.cols; ++c) {
      const float s1 = with.sigma.at(c, r), s0 = without.sigma.at(c, r);
      if (s1 == with.sigma.nodata || s0 == without.sigma.nodata) continue;
      const double east = with.sigma.eastOfCol(c);
      if (strip ? std::fabs(east) > 0.5 * kStrip : east > -4.0 * kStrip) continue;
      const double added = static_cast<double>(s1) * s1 - static_cast<double>(s0) * s0;
      worst = std::max(worst, std::fabs(added - expected) / expected);
      ++cells;
    }
  }
  CHECK_TRUE(cells > 20);
  return worst;
}

}  // namespace

TEST_GROUP(SharedHeightError){};

TEST(SharedHeightError, AddsTheSharedVarianceOfTheKrigingWeights) {
  const Cloud cloud = planeOfTwoPairs();
  const areomap::DemGrid grid = gridAround(cloud.points, 0.02);
  KrigingOptions o;
  o.threads = 1;
  const KrigingResult without = krigeDem(cloud.points, grid, o);
  const double var = 4e-6;  // (2 mm)^2, as large as the points' own noise
  const SharedHeightError correlated = oneDimensional(var, var, var);
  o.point_pairs = &cloud.pairs;
  o.shared_error = &correlated;
  const KrigingResult with = krigeDem(cloud.points, grid, o);
  // The heights do not move.
  for (std::size_t i = 0; i < with.elevation.values.size(); ++i)
    CHECK_EQUAL(without.elevation.values[i], with.elevation.values[i]);
  const double west = largestDeparture(with, without, false, var);
  const double strip = largestDeparture(with, without, true, var);
  std::printf("\n  added variance against g^T C g: west %.2e, strip (fully correlated) %.2e relative\n", west,
              strip);
  CHECK_TRUE(west < 1e-3);  // float rasters
  CHECK_TRUE(strip < 1e-3);
  // Independent pair errors average in the strip: each cell's added variance is W3^2 var + W8^2 var < var.
  const SharedHeightError independent = oneDimensional(var, var, 0.0);
  o.shared_error = &independent;
  const KrigingResult averaged = krigeDem(cloud.points, grid, o);
  CHECK_TRUE(largestDeparture(averaged, without, false, var) < 1e-3);
  double most = 0.0;
  for (int r = 0; r < averaged.sigma.rows; ++r) {
    for (int c = 0; c < averaged.sigma.cols; ++c) {
      if (std::fabs(averaged.sigma.eastOfCol(c)) > 0.5 * kStrip) continue;
      const float s1 = averaged.sigma.at(c, r), s0 = without.sigma.at(c, r);
      if (s1 == averaged.sigma.nodata || s0 == without.sigma.nodata) continue;
      most = std::max(most, (static_cast<double>(s1) * s1 - static_cast<double>(s0) * s0) / var);
    }
  }
  std::printf("  independent pairs in the strip: largest added variance %.3f of var\n", most);
  CHECK_TRUE(most < 0.8);
}

TEST(SharedHeightError, CellVarianceOfHandWeights) {
  // Two neighbours of pair 3 and one shared half-half with pair 8, weights 0.5, 0.3, 0.2.
  std::vector<PointPairs> pairs(3);
  pairs[0].pair[0] = 3;
  pairs[0].fraction[0] = 1.f;
  pairs[1].pair[0] = 3;
  pairs[1].fraction[0] = 1.f;
  pairs[2].pair[0] = 3;
  pairs[2].pair[1] = 8;
  pairs[2].fraction[0] = pairs[2].fraction[1] = 0.5f;
  const int32_t idx[3] = {0, 1, 2};
  const double w[3] = {0.5, 0.3, 0.2};
  const SharedHeightError s = oneDimensional(4.0, 9.0, 1.5);
  // W3 = 0.9, W8 = 0.1: 0.81 * 4 + 2 * 0.09 * 1.5 + 0.01 * 9.
  DOUBLES_EQUAL(0.81 * 4.0 + 0.27 + 0.09, s.cellVariance(pairs, 3, idx, w, 0.0, 0.0, 0.0), 1e-12);
}
