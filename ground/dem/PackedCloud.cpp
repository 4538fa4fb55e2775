#include "ground/dem/PackedCloud.hpp"

#include <algorithm>
#include <stdexcept>

#include "ground/dense/LineId.hpp"

namespace areomap::dem {

PackedCloud::PackedCloud(const Vec3& origin_site_m)
    : origin_(origin_site_m),
      north0_m_(origin_site_m.x()),
      east0_m_(origin_site_m.y()),
      up0_m_(-origin_site_m.z()) {}

void PackedCloud::push(const DemPoint& p) {
  // line = line_base + row with 0 <= row < kLineRowsPerPair for any line, -1 (no line) included.
  const int64_t row =
      ((p.line % dense::kLineRowsPerPair) + dense::kLineRowsPerPair) % dense::kLineRowsPerPair;
  const int64_t base = p.line - row;
  if (runs_.empty() || runs_.back().line_base != base)
    runs_.push_back(Run{base, points_.size(), points_.size()});
  points_.push_back(Packed{static_cast<float>(p.north_m - north0_m_), static_cast<float>(p.east_m - east0_m_),
                           static_cast<float>(p.elevation_m - up0_m_), static_cast<float>(p.sigma_m),
                           static_cast<uint16_t>(row)});
  ++runs_.back().end;
}

void PackedCloud::append(const PackedCloud& other) {
  if (other.empty()) return;
  if (other.origin_ != origin_)
    throw std::invalid_argument("PackedCloud::append: the clouds' origins differ");
  for (const Run& r : other.runs_) {
    if (r.first == r.end) continue;
    if (runs_.empty() || runs_.back().line_base != r.line_base)
      runs_.push_back(Run{r.line_base, points_.size(), points_.size()});
    points_.insert(points_.end(), other.points_.begin() + static_cast<std::ptrdiff_t>(r.first),
                   other.points_.begin() + static_cast<std::ptrdiff_t>(r.end));
    runs_.back().end = points_.size();
  }
}

DemPoint PackedCloud::at(const Run& run, std::size_t i) const {
  const Packed& q = points_[i];
  DemPoint p;
  p.north_m = north0_m_ + static_cast<double>(q.north);
  p.east_m = east0_m_ + static_cast<double>(q.east);
  p.elevation_m = up0_m_ + static_cast<double>(q.up);
  p.sigma_m = static_cast<double>(q.sigma_m);
  p.line = run.line_base + q.row;
  return p;
}

DemPoint PackedCloud::at(std::size_t i) const {
  const auto it = std::upper_bound(runs_.begin(), runs_.end(), i,
                                   [](std::size_t k, const Run& r) { return k < r.first; });
  if (it == runs_.begin() || i >= size()) throw std::out_of_range("PackedCloud::at: no such point");
  return at(*(it - 1), i);
}

void PackedCloud::release() {
  std::vector<Packed>().swap(points_);
  std::vector<Run>().swap(runs_);
}

}  // namespace areomap::dem
