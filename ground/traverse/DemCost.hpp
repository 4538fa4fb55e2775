// The DEM registration's cost (DemRegistration.hpp), shared by the registration and the pose hypotheses
// (PoseHypotheses.hpp): site B's DEM cells as samples, the elevation differences against site A's DEM under a
// relative pose, their weighted moments and the design effect of their spatial correlation.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "ground/traverse/DemRegistration.hpp"
#include "ground/traverse/SiteProducts.hpp"

namespace areomap::traverse::demcost {

// Added to every cell's sigma: no cell weighs more than 2 cm's worth.
inline constexpr double kFloorSigmaM = 0.02;

struct Sample {
  Eigen::Vector3d b_m;  // cell centre on the surface, B's frame
  double sigma2 = 0.0;  // B's dem_sigma^2 (0 without one)
};

// A sigma layer at (x, y): 0 without a layer, infinite where it has no value.
double sigmaAt(const std::optional<DemGrid>& sigma, double x, double y);

// B's cells at `spacing_m` within max_range_m of B's origin and with dem_sigma below max_sigma_m.
std::vector<Sample> samplesOf(const SiteProducts& b, const DemGrid& dem, double spacing_m,
                              const RegistrationParams& params);

// The fewest common samples at params.sample_spacing_m that make the overlap min_overlap_cells of A's cells
// (at least 20).
int minSamples(const SiteProducts& a, const SiteProducts& b, const RegistrationParams& params);

struct Moments {
  double w = 0.0, wd = 0.0, wdd = 0.0;
  double dd = 0.0, ss = 0.0;  // unweighted: the differences' squares, their dem_sigma variances
  int n = 0;
  // Weighted sums over the samples' positions in A's frame (x north, y east) for the plane of the
  // differences: w x, w y, w x^2, w x y, w y^2, w x d, w y d (summed only when the fit solves the tilt,
  // RegistrationParams::tilt_sigma_rad > 0; zero otherwise).
  double wx = 0.0, wy = 0.0, wxx = 0.0, wxy = 0.0, wyy = 0.0, wxd = 0.0, wyd = 0.0;
  double mean() const { return wd / w; }
  double variance() const;
  // The relative tilt that best levels the differences at this pose, and their weighted variance then. A
  // small turn omega about A's x and y changes a difference by omega_x y - omega_y x (to first order, the
  // DEM's slope times the sample's height left out), so the tilt is a plane fitted to the differences, its
  // two slopes drawn to zero by the prior sigma `tilt_sigma_rad` (weighed against variance() per sample as
  // if the samples were independent). With tilt_sigma_rad 0 the tilt is zero and the variance variance().
  Eigen::Vector2d levellingTilt(double tilt_sigma_rad) const;
  double levelledVariance(double tilt_sigma_rad) const;
};

// The elevation differences (A's DEM minus B's surface moved into A) of every sample under `pose`.
Moments moments(const SiteProducts& a, const DemGrid& dem_a, const std::vector<Sample>& samples,
                const RelativePose& pose, const RegistrationParams& params);

// The variance inflation of a mean of the elevation differences under `pose` through their spatial
// correlation: over square blocks of side L, (variance of the block means) / (variance of one difference /
// samples a block), the largest over L doubling from 4 sample spacings while at least 8 blocks are filled;
// differences beyond 3 times `rms_m` are left out (as the trimmed solution does). At least 1.
double designEffect(const SiteProducts& a, const std::vector<Sample>& samples, const RelativePose& pose,
                    const RegistrationParams& params, double rms_m);

}  // namespace areomap::traverse::demcost
