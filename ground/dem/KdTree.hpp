// A static 2-D k-d tree over points in the plane (site north/east), for the k nearest neighbours of a
// kriging cell. Built once (median splits, implicit layout in one index array), queried many times. Beside
// it, PointBuckets: the same answer, faster, for a cell next to one whose neighbours are known.
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
  // The input index of the j-th point in leaf order (0 <= j < size()): neighbours in this order lie near
  // each other, as a leaf's points do.
  int32_t leafIndex(std::size_t j) const { return points_[j].index; }

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

// Uniform buckets over the same points, for the k nearest of a query near one whose neighbours are known
// (the next kriging cell along a row): given a bound on the k-th distance (the farthest of the last cell's
// neighbours from this query), only the buckets within it are read. The answer is returned only when it is
// unique, i.e. when the k + 1 nearest distances are all different: then it is exactly KdTree2::nearest's,
// order included; with a tie (points on a lattice, duplicates), too few points within the bound, or too
// many points to read (sparse parts of the cloud), it returns -1 and the caller asks the k-d tree, whose
// tie order (the order of its search) decides.
class PointBuckets {
 public:
  PointBuckets() = default;
  // Keeps a copy of the coordinates; about kPointsPerBucket points per bucket over the bounding box (no
  // buckets at all, so every query declines, when a coordinate is not finite).
  PointBuckets(const std::vector<double>& x, const std::vector<double>& y);

  // The k nearest points of (qx, qy) as KdTree2::nearest gives them (k <= kMaxBucketNeighbours), given
  // that at least k points lie within max_dist2 (squared distance); -1 when not unique or too costly.
  int nearestWithin(double qx, double qy, int k, double max_dist2, int32_t* index, double* dist2) const;

  static constexpr int kMaxBucketNeighbours = 64;
  static constexpr int kPointsPerBucket = 3;
  static constexpr int kMaxPointsRead = 256;  // beyond this the k-d tree is faster

 private:
  double x0_ = 0.0, y0_ = 0.0, inv_cell_ = 1.0;
  int cols_ = 0, rows_ = 0;
  std::vector<int32_t> start_;  // rows_ * cols_ + 1 offsets into the points, bucket by bucket (row-major)
  std::vector<double> x_, y_;   // the points, bucket by bucket
  std::vector<int32_t> index_;  // into the input
};

}  // namespace areomap::dem
