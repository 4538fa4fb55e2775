// The relative poses of two sites that their DEMs cannot tell apart (cross-site ties, step 1, when the
// images do not confirm the registration). The DEM registration (DemRegistration.hpp) takes the pose where
// the two DEMs differ least; where the relief they share is low against their errors, and those errors are
// not independent from cell to cell (a DEM's errors grow with range and come in patches), the DEMs agree as
// well at poses far from that one as its covariance allows, and the true pose may be among them.
//
// Which poses the DEMs cannot tell apart is measured on the DEMs themselves: over the registration's coarse
// grid of its search window (B's cells a step apart), each pose's variance of the elevation differences V(p)
// against the least V0 of the grid and of the registered pose. V0 is itself an estimate of the DEMs' noise
// variance from n samples whose spatial correlation inflates its variance by the design effect D (measured
// on the differences at that pose, DemCost.hpp), so its relative standard error is sqrt(2 D / n); a pose
// whose V(p) lies within `sigmas` such errors of V0 fits the DEMs as well as their noise lets one say. Those
// poses are the hypotheses, the best-fitting first, each with a covariance that covers its grid cell (half a
// step per axis, so that 3 sigmas reach the neighbours) and its height from the differences' mean. The grid
// is levelled at the registration's tilt when it registered (its tilt and covariance carried), else at the
// a-priori tilt with the tilt's prior sigma.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "ground/traverse/DemRegistration.hpp"
#include "ground/traverse/SiteProducts.hpp"

namespace areomap::traverse {

// The most hypotheses tried: each costs the images a first matching pass (a few seconds of CPU on a
// navcam-like pair), and a leg whose DEMs allow more poses than this is tried on the best-fitting of them.
inline constexpr int kMaxPoseHypotheses = 24;

struct PoseHypothesis {
  RelativePose a_from_b;
  PoseMatrix covariance = PoseMatrix::Zero();  // x, y, z (m), heading, tilt x, tilt y (rad)
  double variance_m2 = 0.0;                    // of the DEM differences there
};

struct PoseHypotheses {
  std::vector<PoseHypothesis> poses;  // best-fitting first, at most kMaxPoseHypotheses
  int plausible = 0;                  // grid poses within the bound (poses keeps the first of them)
  double best_variance_m2 = 0.0;      // V0
  double bound_m2 = 0.0;              // the largest V(p) taken, at the samples V0 had
  double design_effect = 1.0;
  int samples = 0;
  std::string summary;  // one sentence: how many poses the DEMs allow and why
};

// The hypotheses about `registration` (registerDems' result for this pair, its window `params`); none when
// the DEMs do not overlap.
PoseHypotheses demPoseHypotheses(const SiteProducts& a, const SiteProducts& b,
                                 const DemRegistration& registration, const RegistrationParams& params,
                                 double sigmas);

}  // namespace areomap::traverse
