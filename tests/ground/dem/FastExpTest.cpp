#include <cmath>
#include <limits>
#include <random>

#include "ground/dem/FastExp.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dem;

TEST_GROUP(FastExp){};

// Against std::exp over the covariances' arguments (-3 h / range, h up to many ranges), both signs, and the
// ends where std::exp takes over: within 3 units in the last place; NaN and infinities as std::exp.
TEST(FastExp, WithinThreeUlpOfStdExp) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-720.0, 720.0), small(-1.0, 1.0);
  double worst_ulp = 0.0;
  for (int i = 0; i < 200000; ++i) {
    const double x = i % 2 == 0 ? u(rng) : small(rng) * std::pow(10.0, -(i % 12));
    const double e = std::exp(x), f = fastExp(x);
    if (e == 0.0 || std::isinf(e)) {
      CHECK_EQUAL(e, f);
      continue;
    }
    const double ulp = std::nextafter(e, std::numeric_limits<double>::infinity()) - e;
    worst_ulp = std::max(worst_ulp, std::fabs(f - e) / ulp);
  }
  CHECK(worst_ulp <= 3.0);
  CHECK(worst_ulp > 0.0);  // not std::exp itself
  CHECK(std::isnan(fastExp(std::numeric_limits<double>::quiet_NaN())));
  CHECK_EQUAL(0.0, fastExp(-std::numeric_limits<double>::infinity()));
  CHECK_EQUAL(1.0, fastExp(0.0));
}
