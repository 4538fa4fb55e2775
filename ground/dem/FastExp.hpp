// exp(x) inline, for the kriging's covariances (a few hundred per cell: Kriging.cpp, KrigingSystem.cpp).
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

namespace areomap::dem {

namespace detail {
// 2^(j / 64), j = 0..63.
struct ExpTable {
  double at[64];
  ExpTable() {
    for (int j = 0; j < 64; ++j) at[j] = std::exp2(j / 64.0);
  }
};
inline const ExpTable& expTable() {
  static const ExpTable table;
  return table;
}
}  // namespace detail

// exp(x) within 3 units in the last place (std::exp's own error is below one): x = k ln2 / 64 + r with
// |r| <= ln2 / 128 (ln2 in two parts, k ln2's high part exact), exp(r) by its Taylor series to r^6 (the
// next term below 1e-19), times 2^(k / 64) from a table. Outside +-700 (and for NaN) std::exp itself.
inline double fastExp(double x) {
  if (!(x > -700.0 && x < 700.0)) return std::exp(x);
  constexpr double kLn2Hi = 6.93147180369123816490e-01;  // fdlibm's: 32 significant bits
  constexpr double kLn2Lo = 1.90821492927058770002e-10;
  constexpr double kRound = 6755399441055744.0;  // 1.5 * 2^52: adding it rounds to an integer
  const double kd = (x * (64.0 / 0.69314718055994530942) + kRound) - kRound;
  const int k = static_cast<int>(kd);
  const double r = (x - kd * (kLn2Hi / 64.0)) - kd * (kLn2Lo / 64.0);
  const double p =
      1.0 + r * (1.0 + r * (1.0 / 2 + r * (1.0 / 6 + r * (1.0 / 24 + r * (1.0 / 120 + r * (1.0 / 720))))));
  const int64_t bits = static_cast<int64_t>(1023 + (k >> 6)) << 52;  // 2^(k >> 6), in range for |x| < 700
  double scale;
  std::memcpy(&scale, &bits, sizeof scale);
  return detail::expTable().at[k & 63] * p * scale;
}

}  // namespace areomap::dem
