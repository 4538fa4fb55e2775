// A static 2-D k-d tree over points in the plane (site north/east), for the k nearest neighbours of a
// kriging cell. Built once (median splits, implicit layout in one index array), queried many times.
#pragma once

#include <cstdint>
#include <vector>

namespace areomap::dem {

class KdTree2 {
 public:
  KdTree2() = default;
  // Keeps a copy of the coordinates. n >= 0.
  KdTree2(const std::vector<double>& x, const std::vector<double>& y);

  // The k nearest points of (qx, qy), nearest first: indices into the input and squared distances.
  // Returns how many were found (min(k, n)). `max_dist2` (optional) bounds the search radius.
  int nearest(double qx, double qy, int k, int32_t* index, double* dist2,
              double max_dist2 = 1e300) const;
  std::size_t size() const { return points_.size(); }

 private:
  struct Node {
    int32_t begin, end;  // range in order_
    int32_t left, right; // child nodes, -1 for a leaf
    int8_t axis;
    double split;
  };
  // A point in leaf order: the query reads a leaf's points from one contiguous run of memory.
  struct Point {
    double x, y;
    int32_t index;  // into the input
  };
  int32_t build(int32_t begin, int32_t end, int depth);
  std::vector<double> x_, y_;  // the input, during the build only
  std::vector<int32_t> order_;  // during the build only
  std::vector<Node> nodes_;
  std::vector<Point> points_;  // the input in leaf order
};

}  // namespace areomap::dem
