// The dense cloud as the DEM stage keeps it (a navcam panorama has ~1.7e7 points): 18 bytes a point
// instead of a DemPoint's 40, so that the whole cloud, which the outlier filter and the grid need at once,
// fits beside the binning. Per point: its position as float offsets from the cloud's origin (the gimbal
// centre: within 2^-24 of its distance from it, 4 um at 60 m, far below the matching noise), its height
// sigma as a float (the float points.ply writes) and its rectified row; its line's pair part
// (dense::lineId(pair, 0), LineId.hpp) is kept once per run of points that share it, which one pair's
// points are. A point read back is the DemPoint pushed with those roundings, its line exact.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "firmware_core/base/EigenTypes.hpp"
#include "ground/cli/Parallel.hpp"
#include "ground/dem/Kriging.hpp"

namespace areomap::dem {

class PackedCloud {
 public:
  PackedCloud() : PackedCloud(Vec3::Zero()) {}
  // origin: site frame (X north, Y east, Z down), metres.
  explicit PackedCloud(const Vec3& origin_site_m);

  // Points of one line base (one pair's) in a row of the cloud: [first, end).
  struct Run {
    int64_t line_base = 0;
    std::size_t first = 0, end = 0;
  };

  std::size_t size() const { return points_.size(); }
  bool empty() const { return points_.empty(); }
  const std::vector<Run>& runs() const { return runs_; }
  const Vec3& origin() const { return origin_; }

  void reserve(std::size_t n) { points_.reserve(n); }
  void push(const DemPoint& p);
  // Appends `other`'s points in their order (the same origin; else std::invalid_argument).
  void append(const PackedCloud& other);
  // Point i of `run` (its first <= i < end), as pushed with the roundings above.
  DemPoint at(const Run& run, std::size_t i) const;
  // Point i, its run found by bisection.
  DemPoint at(std::size_t i) const;
  // Point i's north coordinate alone (at(i).north_m, the same double): a cheap first test of a point.
  double northOf(std::size_t i) const { return north0_m_ + static_cast<double>(points_[i].north); }
  // fn(i, point) for every point in order.
  template <class Fn>
  void forEach(const Fn& fn) const {
    forEachIn(0, size(), fn);
  }
  // fn(i, point) for the points begin <= i < end, in order.
  template <class Fn>
  void forEachIn(std::size_t begin, std::size_t end, const Fn& fn) const {
    for (const Run& r : runs_) {
      for (std::size_t i = std::max(begin, r.first); i < std::min(end, r.end); ++i) fn(i, at(r, i));
    }
  }
  // Keeps the points i for which keep(i, point) holds, in their order; moved(from, to) for each kept point
  // (to <= from), so that the caller's per-point data follow. Frees nothing: the capacity stays.
  template <class Keep, class Moved>
  void keepIf(const Keep& keep, const Moved& moved);
  // Frees the points (size 0, no capacity).
  void release();

 private:
#pragma pack(push, 1)
  struct Packed {
    float north, east, up;  // offsets from the origin, metres
    float sigma_m;
    uint16_t row;  // the line less its run's line_base
  };
#pragma pack(pop)
  static_assert(sizeof(Packed) == 18, "PackedCloud::Packed is packed");

  Vec3 origin_;
  double north0_m_, east0_m_, up0_m_;
  std::vector<Packed> points_;
  std::vector<Run> runs_;
};

// The chunks of `chunk_points` points of `cloud` (the last one shorter) handed to threads: fn(chunk, i,
// point) for the points of each chunk, in their order. What a chunk makes is its own; merged afterwards in
// chunk order, it is the same for any thread count.
inline std::size_t chunkCount(const PackedCloud& cloud, std::size_t chunk_points) {
  return (cloud.size() + chunk_points - 1) / chunk_points;
}
template <class Fn>
void forEachChunk(const PackedCloud& cloud, std::size_t chunk_points, const Fn& fn) {
  cli::parallelFor(chunkCount(cloud, chunk_points), 0, [&](std::size_t chunk) {
    const std::size_t begin = chunk * chunk_points;
    cloud.forEachIn(begin, std::min(cloud.size(), begin + chunk_points),
                    [&](std::size_t i, const DemPoint& p) { fn(chunk, i, p); });
  });
}

template <class Keep, class Moved>
void PackedCloud::keepIf(const Keep& keep, const Moved& moved) {
  std::vector<Run> runs;
  std::size_t kept = 0;
  for (const Run& r : runs_) {
    const std::size_t first = kept;
    for (std::size_t i = r.first; i < r.end; ++i) {
      if (!keep(i, at(r, i))) continue;
      moved(i, kept);
      points_[kept++] = points_[i];
    }
    if (kept > first) runs.push_back(Run{r.line_base, first, kept});
  }
  points_.resize(kept);
  runs_.swap(runs);
}

}  // namespace areomap::dem
