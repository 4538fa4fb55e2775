// The paper's three precision measures (Di, Xu, Li §3.5), shared by the rover status and the ground report.
// Every figure is the MEAN ABSOLUTE difference (the paper's "average of absolute differences"), per axis,
// plus the mean Euclidean length (`dist`); `count` is the number of differences averaged.
//   method 1: back-projection residuals of the adjusted ground points in every image that observes them
//             (measured ideal pixel minus projection), pixels.
//   method 2: 3-D differences of an inter-stereo tie point triangulated from either stereo pair (each
//             pair's two rays alone), site-frame metres; every pair against the first pair that sees it.
//   method 3: 2-D differences after transfer: the point triangulated from one pair is projected into the
//             images of the other pair and compared with the measured pixel there, pixels.
// Computed on the network's current EO: call once on the a-priori EO ("before") and once after. Rejected
// observations and unsolvable points (those the adjustment leaves out) are left out here too.
#pragma once

#include <cstdint>

#include "firmware_core/adjust/Network.hpp"

namespace areomap {

struct ImageDifferences {
  double x = 0.0;
  double y = 0.0;
  double dist = 0.0;
  int32_t count = 0;
};

struct GroundDifferences {
  double x = 0.0;
  double y = 0.0;
  double z = 0.0;
  int32_t count = 0;
};

struct TiePointCounts {
  int32_t intra = 0;     // seen by one stereo pair only
  int32_t inter = 0;     // seen by two or more pairs
  int32_t rejected = 0;  // rejected observations
};

ImageDifferences precisionMethod1(const Network& net);
GroundDifferences precisionMethod2(const Network& net);
ImageDifferences precisionMethod3(const Network& net);
TiePointCounts countTiePoints(const Network& net);

}  // namespace areomap
