// Where a median of ratios crosses chi-square's median (the DEM noise's fractions, BinnedCloud.cpp).
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace areomap::dem {

inline constexpr double kChiSquare1Median = 0.454936;  // median of chi-square with one degree of freedom

// The value x in [lo, hi] at which the median of ratio(k, x) over k = 0..n-1 is chi-square's median (one
// degree of freedom), the median moving the other way from `falls` (true: it falls as x grows);
// bisection to 1e-4 relative. lo when the median is already on the far side at lo.
template <class Ratio>
double medianCrossing(std::size_t n, double lo, double hi, bool falls, const Ratio& ratio_of) {
  std::vector<double> ratio(n);
  const auto medianAt = [&](double x) {
    for (std::size_t k = 0; k < n; ++k) ratio[k] = ratio_of(k, x);
    const auto mid = ratio.begin() + static_cast<std::ptrdiff_t>(n / 2);
    std::nth_element(ratio.begin(), mid, ratio.end());
    return *mid;
  };
  const auto beyond = [&](double x) {
    return falls ? medianAt(x) > kChiSquare1Median : medianAt(x) < kChiSquare1Median;
  };
  if (!beyond(lo)) return lo;
  if (falls) {
    for (int k = 0; k < 60 && beyond(hi); ++k) hi *= 4.0;
  } else if (beyond(hi)) {
    return hi;
  }
  for (int k = 0; k < 40 && hi - lo > 1e-4 * hi; ++k) {
    const double mid = 0.5 * (lo + hi);
    (beyond(mid) ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace areomap::dem
