// The terrain's row-wise fBm (FbmAlongY, used to fill the grids) against the point-wise fbm() it stands for:
// the same doubles bit for bit, over rows and columns that cross many lattice cells of every octave, on both
// sides of zero, for the octave counts and gains the terrain uses.
#include <cstdint>
#include <cstring>
#include <random>

#include "ground/sim/Noise.hpp"

#include <CppUTest/TestHarness.h>

namespace {

bool sameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

}  // namespace

TEST_GROUP(Noise){};

TEST(Noise, RowWiseFbmIsThePointWiseOneBitForBit) {
  struct Case {
    double wavelength;
    int octaves;
    double gain;
  };
  const Case cases[] = {{32.0, 14, 0.55}, {8.0, 3, 0.5}, {1.5, 3, 0.6}, {0.4, 3, 0.7}, {32.0, 1, 0.55}};
  std::mt19937_64 rng(20261206);
  std::uniform_real_distribution<double> origin(-150.0, 150.0), cell(0.005, 0.2);
  int compared = 0, differing = 0;
  for (const Case& c : cases) {
    for (int row = 0; row < 20; ++row) {
      const uint64_t seed = rng();
      const double x = origin(rng), y0 = origin(rng), step = cell(rng);
      areomap::sim::FbmAlongY along(seed, x, c.wavelength, c.octaves, c.gain);
      for (int j = 0; j < 2000; ++j) {
        const double y = y0 + j * step;
        ++compared;
        if (!sameBits(along(y), areomap::sim::fbm(seed, x, y, c.wavelength, c.octaves, c.gain))) ++differing;
      }
    }
  }
  CHECK_EQUAL(100 * 2000, compared);
  CHECK_EQUAL(0, differing);
}
