// ldltSolve3 and fullPivInverse3 against Eigen's LDLT<Mat3> and FullPivLU<Mat3>: every bit the same, over
// normal matrices of intersection (J^T J of rays a few degrees apart), general and symmetric random
// matrices over many scales, nearly singular ones, ones with equal diagonals (pivot ties) and zeros.
#include <cstdint>
#include <cstring>
#include <random>

#include <Eigen/Dense>

#include "firmware_core/base/Solve3.hpp"

#include "CppUTest/TestHarness.h"

using namespace areomap;

namespace {

bool sameBits(const double* a, const double* b, int n) { return std::memcmp(a, b, sizeof(double) * n) == 0; }

// A matrix of the kind the tests feed: k = the case (cycled), from `rng`.
Mat3 solve3Case(int k, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> e(-12, 12), small(-2, 2), index(0, 2);
  Mat3 m;
  switch (k % 6) {
    case 0: {  // J^T J of two views: 4 rows, columns of very different size (range vs across)
      Eigen::Matrix<double, 4, 3> j;
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 3; ++c) j(r, c) = u(rng) * std::ldexp(1.0, c == 2 ? e(rng) / 3 - 4 : 6);
      m = j.transpose() * j;
      break;
    }
    case 1:  // general, entries over many scales
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) m(r, c) = u(rng) * std::ldexp(1.0, e(rng));
      break;
    case 2: {  // symmetric, indefinite
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c <= r; ++c) m(r, c) = m(c, r) = u(rng) * std::ldexp(1.0, e(rng));
      break;
    }
    case 3: {  // nearly singular: rank 2 plus a tiny part
      const Vec3 a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng)), c(u(rng), u(rng), u(rng));
      m = a * a.transpose() + b * b.transpose() + std::ldexp(1.0, -40 - e(rng)) * c * c.transpose();
      break;
    }
    case 4:  // small integers: equal entries and diagonals (pivot ties), zeros
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c <= r; ++c) m(r, c) = m(c, r) = small(rng);
      break;
    default:  // zero rows and columns
      m = Mat3::Zero();
      m(index(rng), index(rng)) = u(rng);
      m(index(rng), index(rng)) = u(rng);
      break;
  }
  return m;
}

}  // namespace

TEST_GROUP(Solve3){};

TEST(Solve3, LdltSolveEqualsEigenBitForBit) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  long long differ = 0;
  constexpr int kCases = 300000;
  for (int k = 0; k < kCases; ++k) {
    const Mat3 a = solve3Case(k, rng);
    const Vec3 b(u(rng), u(rng), u(rng));
    const Vec3 eigen = a.ldlt().solve(b);
    const Vec3 ours = ldltSolve3(a, b);
    differ += sameBits(eigen.data(), ours.data(), 3) ? 0 : 1;
  }
  LONGS_EQUAL(0, differ);
}

TEST(Solve3, FullPivInverseEqualsEigenBitForBit) {
  std::mt19937_64 rng(2);
  long long differ = 0, invertible = 0;
  constexpr int kCases = 300000;
  for (int k = 0; k < kCases; ++k) {
    const Mat3 a = solve3Case(k, rng);
    const Eigen::FullPivLU<Mat3> lu(a);
    Mat3 ours = Mat3::Zero();
    const bool ok = fullPivInverse3(a, ours);
    if (ok != lu.isInvertible()) {
      ++differ;
      continue;
    }
    if (!ok) continue;
    ++invertible;
    const Mat3 eigen = lu.inverse();
    differ += sameBits(eigen.data(), ours.data(), 9) ? 0 : 1;
  }
  LONGS_EQUAL(0, differ);
  CHECK(invertible > kCases / 2);
}
