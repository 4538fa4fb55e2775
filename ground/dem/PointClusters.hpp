// Single-linkage clusters of points in the plane: two points are linked when they are at most link_m apart,
// and a cluster is a connected set of links. The kriging's support rule (Kriging.hpp,
// KrigingOptions::min_cluster_points) uses the size of each point's cluster.
#pragma once

#include <cstdint>
#include <vector>

namespace areomap::dem {

// The size of the cluster of every point (x[i], y[i]), exact for the link distance `link_m` > 0. Uniform
// buckets of side link_m / sqrt(2) (the points of one bucket are all linked), then the pairs of buckets up to
// two apart, until one link joins them. Non-finite coordinates make a point a cluster of its own.
std::vector<int32_t> clusterSizes(const std::vector<double>& x, const std::vector<double>& y, double link_m);

}  // namespace areomap::dem
