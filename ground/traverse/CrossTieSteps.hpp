// The steps of findCrossSiteTies (CrossSiteTies.hpp) between the registration and the result, for
// CrossSiteTies.cpp alone: the candidates matched under a pose, and the geometric check of what they gave.
#pragma once

#include <cstdint>
#include <vector>
#include <vector>

#include <Eigen/Core>

#include "ground/traverse/CrossSiteTies.hpp"

namespace areomap::traverse {

// The Förstner points of each of B's images (full-resolution pixels), found once for both passes.
using SourcePoints = std::vector<std::vector<Eigen::Vector2d>>;
SourcePoints sourcePoints(const SiteProducts& b, const CrossTieParams& params);

// Steps 2 and 3 (CrossTieMatching.cpp): every stride-th point of `points` (B's images) cast through B's DEM
// under `pose` (covariance `pose_cov`: x, y, z, heading, tilt) and matched into A's (and B's other) images;
// out.ties becomes the candidates that reached an image of A, their points numbered from first_point, and
// out.counts, out.counts_in_a count what each gate refused. The candidates are matched in parallel
// (cli::threadCount()); the result does not depend on the thread count.
void matchTies(const SiteProducts& a, const SiteProducts& b, const SourcePoints& points,
               const RelativePose& pose, const PoseMatrix& pose_cov, const CrossTieParams& params,
               int64_t first_point, int stride, CrossTieResult& out);

// Step 4 (CrossTieCheck.cpp): the bundle of the pose and the ties' points from all their observations with
// a weak prior on `pose` (also the start), trimmed round by round; out.a_from_b, its sigma and covariance,
// out.rms_px and out.ties (the kept ties with their kept observations) are the result.
void checkTies(const SiteProducts& a, const SiteProducts& b, const RelativePose& pose,
               const CrossTieParams& params, CrossTieResult& out);

}  // namespace areomap::traverse
