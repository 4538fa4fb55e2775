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
  double mean() const { return wd / w; }
  double variance() const;
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
