// Experimental semivariogram of scattered heights and a fitted model (spherical, exponential or
// Gaussian, chosen by the weighted fit; Cressie's weights N(h) / gamma(h)^2), paper §4.1 and
// shared/reference/camera-models.md "kriging".
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "ground/dem/FastExp.hpp"

namespace areomap::dem {

class KdTree2;

enum class VariogramKind { kSpherical, kExponential, kGaussian };
const char* variogramName(VariogramKind kind);

struct VariogramModel {
  VariogramKind kind = VariogramKind::kSpherical;
  double nugget_m2 = 0.0;
  double partial_sill_m2 = 1.0;
  double range_m = 1.0;  // practical range (exponential/Gaussian reach 95 % of the sill there)
  double fit_error = 0.0;  // weighted residual sum of the fit (comparable between kinds)

  // Correlation part rho(h) in [0, 1], 1 at h = 0.
  double correlation(double h_m) const {
    return correlationWith(h_m, [](double x) { return std::exp(x); });
  }
  // The same with fastExp (FastExp.hpp, within a few units in the last place of std::exp's): the kriging's
  // covariances, a few hundred per cell.
  double correlationFast(double h_m) const { return correlationWith(h_m, fastExp); }
  // gamma(h) = nugget + psill (1 - rho(h)) for h > 0, 0 at h = 0.
  double gamma(double h_m) const;
  double sill() const { return nugget_m2 + partial_sill_m2; }

  template <class Exp>
  double correlationWith(double h_m, const Exp& exp_of) const {
    const double a = std::max(range_m, 1e-12);
    switch (kind) {
      case VariogramKind::kSpherical: {
        if (h_m >= a) return 0.0;
        const double t = h_m / a;
        return 1.0 - 1.5 * t + 0.5 * t * t * t;
      }
      case VariogramKind::kExponential:
        return exp_of(-3.0 * h_m / a);
      case VariogramKind::kGaussian:
        return exp_of(-3.0 * (h_m * h_m) / (a * a));
    }
    return 0.0;
  }
};

struct ExperimentalVariogram {
  std::vector<double> lag_m;    // mean distance of the pairs in each bin
  std::vector<double> gamma_m2; // half the mean squared height difference
  std::vector<int64_t> pairs;
  // With pair noise (robust): each lag's information, sum over its pairs of 1 / (gamma + noise)^2, the fit's
  // weight (Cressie's N / gamma^2 where there is no noise); empty: the fit uses N / gamma^2.
  std::vector<double> fit_weight;
};

// Bins pairs of points up to `max_lag_m` into `bins` lags. With more than `max_pairs` candidate pairs,
// pairs are sampled (deterministically, seeded), each point with its neighbours from the k-d tree and
// random partners, so that short lags are well represented.
// `pair_noise_m2` (optional): the semivariance of the two points' measurement errors, 1/2 Var(e_i - e_j),
// subtracted from each pair's 1/2 (z_i - z_j)^2: the variogram of the noise-free surface. `robust`: each
// lag's semivariance is the MEDIAN over its pairs of 1/2 (z_i - z_j)^2 / 0.4549 less the pair's noise
// (0.4549: the median of chi^2 with 1 degree of freedom, so that it equals the mean for Gaussian
// differences), so that a few gross errors (mismatches) do not make the variogram of the bulk; each pair
// weighted by its precision there, 1 / (semivariance + its noise), so that where the noise varies across
// the cloud (near and far range) the precise pairs make it (fit_weight: each lag's information for the
// fit). With pair noise each sampled point takes 63 neighbours (else 8), so that the dense, precise part
// of the cloud has pairs at the lags of a few kriging neighbourhoods.
// `tree` (optional): a k-d tree built over x and y, used for the neighbours instead of building one (the
// same tree: the same neighbours).
ExperimentalVariogram experimentalVariogram(
    const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& z,
    double max_lag_m, int bins = 20, int64_t max_pairs = 2000000, uint32_t seed = 1,
    const std::function<double(std::size_t, std::size_t)>& pair_noise_m2 = {}, bool robust = false,
    const KdTree2* tree = nullptr);

// Fits each kind (range by golden search on a grid, nugget and partial sill by non-negative weighted
// least squares for each range) and returns the best.
VariogramModel fitVariogram(const ExperimentalVariogram& ev);
VariogramModel fitVariogram(const ExperimentalVariogram& ev, VariogramKind kind);

}  // namespace areomap::dem
