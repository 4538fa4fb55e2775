// The relative pose of two neighbouring sites from their orthoimages, where their DEMs do not register
// (DemRegistration.hpp): the DEM registration compares elevations, and a DEM whose errors are as large as
// the relief the two sites share (a camera with coarse pixels, the overlap in both sites' far field) leaves
// its cost flat and its minimum where the errors put it. The orthoimages of the same ground carry its
// texture (albedo, rocks, the shading of the relief under one sun) at the DEM's cell, far more of it than
// the elevations do at that range, so their normalised cross-correlation peaks at the true pose.
//
// Method: B's ortho cells are moved into A's frame by a levelled relative pose (x, y, heading) and
// correlated (NCC) with A's ortho there, over cells within max_range_m of both sites. A grid search over
// the registration's window (as the DEM search: about ten steps each side, the orthos averaged to the step)
// then a fine one (quarter steps) on the full orthos, and a parabola through the peak on each axis. The
// height is the DEMs' weighted mean difference at that pose. The match is refused when another local peak
// of the coarse search, away from the best, rises more than half way from the grid's median to the best
// (ambiguous), or too few cells are common.
#pragma once

#include <string>

#include "ground/traverse/DemRegistration.hpp"
#include "ground/traverse/SiteProducts.hpp"

namespace areomap::traverse {

struct OrthoRegistration {
  bool ok = false;
  std::string message;  // why not, when not ok
  RelativePose a_from_b;
  Eigen::Matrix4d covariance = Eigen::Matrix4d::Zero();  // x, y, z (m), heading (rad)
  double ncc = 0.0;                                      // at the solution
  double second_ncc = 0.0;                               // the coarse search's second peak (0: none)
  double median_ncc = 0.0;                               // the coarse search's median
  int cells = 0;                                         // common cells at the solution
};

// Both sites need an ortho (SiteProducts::ortho); the window and range are `params`'.
OrthoRegistration registerOrthos(const SiteProducts& a, const SiteProducts& b, const RelativePose& apriori,
                                 const RegistrationParams& params);

}  // namespace areomap::traverse
