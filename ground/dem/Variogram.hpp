// Experimental semivariogram of scattered heights and a fitted model (spherical, exponential or
// Gaussian, chosen by the weighted fit; Cressie's weights N(h) / gamma(h)^2), paper §4.1 and
// shared/reference/camera-models.md "kriging".
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace areomap::dem {

enum class VariogramKind { kSpherical, kExponential, kGaussian };
const char* variogramName(VariogramKind kind);

struct VariogramModel {
  VariogramKind kind = VariogramKind::kSpherical;
  double nugget_m2 = 0.0;
  double partial_sill_m2 = 1.0;
  double range_m = 1.0;  // practical range (exponential/Gaussian reach 95 % of the sill there)
  double fit_error = 0.0;  // weighted residual sum of the fit (comparable between kinds)

  // Correlation part rho(h) in [0, 1], 1 at h = 0.
  double correlation(double h_m) const;
  // gamma(h) = nugget + psill (1 - rho(h)) for h > 0, 0 at h = 0.
  double gamma(double h_m) const;
  double sill() const { return nugget_m2 + partial_sill_m2; }
};

struct ExperimentalVariogram {
  std::vector<double> lag_m;    // mean distance of the pairs in each bin
  std::vector<double> gamma_m2; // half the mean squared height difference
  std::vector<int64_t> pairs;
};

// Bins pairs of points up to `max_lag_m` into `bins` lags. With more than `max_pairs` candidate pairs,
// pairs are sampled (deterministically, seeded), each point with its neighbours from the k-d tree and
// random partners, so that short lags are well represented.
ExperimentalVariogram experimentalVariogram(const std::vector<double>& x, const std::vector<double>& y,
                                            const std::vector<double>& z, double max_lag_m, int bins = 20,
                                            int64_t max_pairs = 2000000, uint32_t seed = 1);

// Fits each kind (range by golden search on a grid, nugget and partial sill by non-negative weighted
// least squares for each range) and returns the best.
VariogramModel fitVariogram(const ExperimentalVariogram& ev);
VariogramModel fitVariogram(const ExperimentalVariogram& ev, VariogramKind kind);

}  // namespace areomap::dem
