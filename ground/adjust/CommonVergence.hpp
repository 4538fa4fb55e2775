// The pairs' common vergence (each pair's right camera turned against its left one about its y axis, all
// pairs alike): the weakest mode of a panorama that reaches its DEM. It shifts every parallax by f delta
// and every height at range r by about r h delta / b, the same way in every pair, so no overlap of pairs
// averages it down. Its random part is in the EO covariance (FullEoCovariance.hpp: ~9 urad on a navcam
// panorama, against ~3 urad if the pairs were independent). A systematic error of the tie points that grows
// with range (a parallax bias of far matches, e.g. textured foreground winning the correlation window)
// moves it further, and no residual shows it: the mode is nearly free.
//
// The check: the network solved again from its near half of the points (by range from the gimbal, split
// at the median) and the common vergence of the two solutions compared. Without systematic errors the
// difference t has the variance v = a^T (C_near - C_all) a of nested least-squares solutions (Hausman: the
// full solution is the efficient one, so Cov(e_near - e_all) = C_near - C_all); what t^2 exceeds it by is a
// systematic part s^2 = max(0, t^2 - v), added to the covariance along the mode's own shape
// u = C a / (a^T C a) (the EO change that goes with a unit common vergence): C + s^2 u u^T. A single
// estimate (one degree of freedom): it widens the DEM sigma where the data show the mode moved by more than
// its noise, and leaves it alone otherwise.
#pragma once

#include <Eigen/Core>

#include "firmware_core/adjust/Network.hpp"
#include "ground/adjust/FullEoCovariance.hpp"

namespace areomap::ground {

struct CommonVergenceCheck {
  bool done = false;             // false: fewer than two stereo pairs, or the near half is not solvable
  double split_range_m = 0.0;    // the median point range
  double sigma_rad = 0.0;        // the covariance's sigma of the common vergence (before)
  double difference_rad = 0.0;   // t: all points' solution minus the near half's
  double expected_sd_rad = 0.0;  // sqrt(v)
  double systematic_rad = 0.0;   // s, added
};

// The mean over stereo pairs of their vergence, as a functional of the EO unknowns (FullEoCovariance's
// order) at the network's current cameras.
Eigen::VectorXd commonVergenceFunctional(const Network& net);

// The mean vergence of `b`'s pairs against `a`'s (radians).
double commonVergenceDifference(const Network& a, const Network& b);

// Checks `solved` (an adjusted network with its rejection flags) as above and adds the systematic part to
// `full` (its covariance).
CommonVergenceCheck addCommonVergenceSystematic(const Network& solved, FullEoCovariance& full);

}  // namespace areomap::ground
