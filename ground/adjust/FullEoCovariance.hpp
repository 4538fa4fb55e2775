// The whole a-posteriori covariance of an adjusted network's exterior orientation, the blocks between
// pairs included: sigma0^2 S^-1 (S - P) S^-1 of EoCovariance.hpp as one dense matrix. The per-pair blocks
// that the network keeps (NetPair::covariance) say how well each pair is oriented but not how its errors go
// with the other pairs': a panorama's pairs share modes that its ties fix weakly (e.g. a common vergence
// of every pair), and their errors then move together. What the DEM sigma needs (ground/dem
// SharedHeightError.hpp): such an error is in every pair's points at once, so no averaging over pairs
// lowers it.
#pragma once

#include <Eigen/Core>

#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/base/Status.hpp"

namespace areomap::ground {

struct FullEoCovariance {
  Status status = Status::kOk;  // kDegenerate: the network is not rigid (no covariance), as EoCovariance
  double sigma0 = 0.0;
  // 12 n x 12 n, pair by pair in network order, each pair's unknowns [left dC (m, site frame), delta (rad,
  // camera frame), right dC, delta] (Constraints.hpp); a single image's right half is zero.
  Eigen::MatrixXd covariance;
  // Its parts, unscaled: S^-1 and P (block-diagonal), so that C = sigma0^2 S^-1 (S - P) S^-1, and a caller
  // can form covariances with another solution of the same network (CommonVergence.cpp).
  Eigen::MatrixXd inverse;
  Eigen::MatrixXd fixed;
};

// At the network's current state (solved by any adjuster); also writes the per-pair blocks and the
// images' sigmas into the network, as FastAdjuster::precisionOf does.
FullEoCovariance fullEoCovariance(Network& net);

}  // namespace areomap::ground
