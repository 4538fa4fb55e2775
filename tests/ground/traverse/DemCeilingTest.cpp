#include <cmath>
#include <random>

#include <Eigen/Dense>

#include "ground/traverse/SiteProducts.hpp"

#include "CppUTest/TestHarness.h"

using namespace areomap;
using namespace areomap::traverse;

namespace {

// A rough DEM with rocks, a ridge and holes of nodata: the rays cross it, graze it, pass under its edges
// and through its holes.
DemGrid roughDem(std::mt19937& rng) {
  DemGrid dem;
  dem.cell_m = 0.05;
  dem.east0_m = -5.0;
  dem.north0_m = 4.5;
  dem.values.resize(std::size_t{203} * 187);  // an odd size: blocks cut at its edges
  dem.cols = 203;
  dem.rows = 187;
  std::normal_distribution<double> noise(0.0, 0.01);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int r = 0; r < dem.rows; ++r) {
    for (int c = 0; c < dem.cols; ++c) {
      const double x = dem.northOfRow(r), y = dem.eastOfCol(c);
      double e = 0.1 * std::sin(0.7 * x) + 0.05 * y + 0.4 * std::exp(-(x * x) / 0.1) + noise(rng);
      if (u(rng) < 0.002) e += 0.3;  // a rock
      dem.at(c, r) = static_cast<float>(e);
    }
  }
  for (int hole = 0; hole < 12; ++hole) {
    const int c0 = static_cast<int>(u(rng) * dem.cols), r0 = static_cast<int>(u(rng) * dem.rows);
    for (int r = r0; r < std::min(dem.rows, r0 + 9); ++r) {
      for (int c = c0; c < std::min(dem.cols, c0 + 13); ++c) dem.at(c, r) = hole % 2 ? dem.nodata : NAN;
    }
  }
  return dem;
}

}  // namespace

TEST_GROUP(DemCeiling){};

// The ceiling only passes over steps that cannot be the crossing: every ray finds the same crossing, to the
// bit, as the cast that makes every step, with any block size.
TEST(DemCeiling, SameCrossingAsEveryStep) {
  std::mt19937 rng(7);
  const DemGrid dem = roughDem(rng);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int hits = 0, misses = 0;
  for (int block : {1, 4, 8, 16}) {
    const DemCeiling ceiling = demCeiling(dem, block);
    for (int k = 0; k < 3000; ++k) {
      // From a mast 0.3-2 m above the ground (or outside the DEM), down at 2-60 degrees.
      const Eigen::Vector3d origin(-5.5 + 11.0 * u(rng), -5.5 + 11.0 * u(rng), -0.3 - 1.7 * u(rng));
      const double azimuth = 2.0 * M_PI * u(rng), depression = (2.0 + 58.0 * u(rng)) * M_PI / 180.0;
      const Eigen::Vector3d d(std::cos(azimuth) * std::cos(depression),
                              std::sin(azimuth) * std::cos(depression), std::sin(depression));
      double t_every = -1.0, t_ceiling = -2.0;
      const bool every = castRayOnDem(dem, origin, d, 15.0, t_every);
      const bool skipped = castRayOnDem(dem, ceiling, origin, d, 15.0, t_ceiling);
      CHECK_EQUAL(every, skipped);
      if (every) {
        CHECK_EQUAL(t_every, t_ceiling);  // the same bits
        ++hits;
      } else {
        ++misses;
      }
    }
  }
  CHECK(hits > 1000);
  CHECK(misses > 100);
}
