#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "ground/dem/MedianGuess.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dem;

namespace {

// The reference: std::nth_element on a copy.
double nthMedian(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

TEST_GROUP(MedianGuess){};

// Sets that drift slowly (the guess mostly hits), jump (it misses), hold ties and zeros, and negative
// values: every median is std::nth_element's, bit for bit, on every iteration index.
TEST(MedianGuess, SameValueAsNthElement) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  MedianGuess guess;
  long long checked = 0;
  for (int set = 0; set < 3000; ++set) {
    const int iteration = set % 3;
    const std::size_t n = 5 + static_cast<std::size_t>(u(rng) * 300);
    double scale = 1e-3 * (1.0 + 0.001 * set);
    if (set % 500 == 499) scale *= 50.0;  // a jump: the band misses
    std::vector<double> v(n);
    for (double& x : v) x = scale * std::fabs(std::log(u(rng) + 1e-12));
    // A zero median, ties, a negative value.
    if (set % 7 == 0) std::fill(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(n / 2 + 1), 0.0);
    if (set % 11 == 0) std::fill(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(n / 3), v.back());
    if (set % 13 == 0) v[0] = -v[0] - 1.0;
    const double expected = nthMedian(v);
    const double got = guess.median(v, iteration);
    CHECK(std::memcmp(&expected, &got, sizeof got) == 0);
    ++checked;
  }
  CHECK_EQUAL(3000, checked);
}

// An iteration index beyond kMaxIterations has no guess and is still exact.
TEST(MedianGuess, IterationWithoutGuess) {
  MedianGuess guess;
  const std::vector<double> v{5.0, 1.0, 4.0, 2.0, 3.0, 9.0};
  DOUBLES_EQUAL(nthMedian(v), guess.median(v, MedianGuess::kMaxIterations + 1), 0.0);
  DOUBLES_EQUAL(4.0, guess.median(v, -1), 0.0);
}
