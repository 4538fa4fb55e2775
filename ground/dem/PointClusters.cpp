#include "ground/dem/PointClusters.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace areomap::dem {

namespace {

struct UnionFind {
  std::vector<std::size_t> parent;
  explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), std::size_t{0}); }
  std::size_t root(std::size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];  // path halving
    return i;
  }
  void join(std::size_t a, std::size_t b) {
    a = root(a);
    b = root(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

// A bucket key from its column and row (each within +-2^31).
int64_t bucketKey(int64_t col, int64_t row) {
  return row * (int64_t{1} << 32) + col;
}

}  // namespace

std::vector<int32_t> clusterSizes(const std::vector<double>& x, const std::vector<double>& y, double link_m) {
  if (x.size() != y.size() || !(link_m > 0.0)) throw std::invalid_argument("clusterSizes: bad input");
  const std::size_t n = x.size();
  const double side = link_m / std::sqrt(2.0);
  const double link2 = link_m * link_m;
  // Points sorted by bucket (row-major); non-finite or out-of-range coordinates get no bucket.
  constexpr double kMaxBucket = 1e9;
  struct Entry {
    int64_t key;
    std::size_t index;
  };
  std::vector<Entry> order;
  order.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double c = std::floor(x[i] / side), r = std::floor(y[i] / side);
    if (!(std::fabs(c) < kMaxBucket && std::fabs(r) < kMaxBucket)) continue;
    order.push_back({bucketKey(static_cast<int64_t>(c), static_cast<int64_t>(r)), i});
  }
  std::sort(order.begin(), order.end(), [](const Entry& a, const Entry& b) {
    return a.key != b.key ? a.key < b.key : a.index < b.index;
  });
  struct Bucket {
    int64_t col, row;
    std::size_t begin, end;  // range in order
  };
  std::vector<Bucket> buckets;
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i;
    while (j < order.size() && order[j].key == order[i].key) ++j;
    const std::size_t p = order[i].index;
    buckets.push_back(
        {static_cast<int64_t>(std::floor(x[p] / side)), static_cast<int64_t>(std::floor(y[p] / side)), i, j});
    i = j;
  }
  UnionFind uf(n);
  for (const Bucket& b : buckets) {
    for (std::size_t k = b.begin + 1; k < b.end; ++k) uf.join(order[b.begin].index, order[k].index);
  }
  // Buckets more than two apart hold no linked points (2 sides = sqrt(2) link); each pair of buckets once,
  // the other one later in the order (same row to the right, or a later row).
  for (const Bucket& b : buckets) {
    for (int64_t dr = 0; dr <= 2; ++dr) {
      for (int64_t dc = -2; dc <= 2; ++dc) {
        if (dr == 0 && dc <= 0) continue;
        const int64_t key = bucketKey(b.col + dc, b.row + dr);
        const auto it = std::lower_bound(order.begin(), order.end(), key,
                                         [](const Entry& e, int64_t k) { return e.key < k; });
        if (it == order.end() || it->key != key) continue;
        const std::size_t first = static_cast<std::size_t>(it - order.begin());
        if (uf.root(order[b.begin].index) == uf.root(order[first].index)) continue;
        bool linked = false;
        for (std::size_t i = b.begin; i < b.end && !linked; ++i) {
          const std::size_t p = order[i].index;
          for (std::size_t j = first; j < order.size() && order[j].key == key && !linked; ++j) {
            const std::size_t q = order[j].index;
            const double dx = x[p] - x[q], dy = y[p] - y[q];
            linked = dx * dx + dy * dy <= link2;
          }
        }
        if (linked) uf.join(order[b.begin].index, order[first].index);
      }
    }
  }
  std::vector<int32_t> size(n, 0), out(n);
  for (std::size_t i = 0; i < n; ++i) ++size[uf.root(i)];
  for (std::size_t i = 0; i < n; ++i) out[i] = size[uf.root(i)];
  return out;
}

}  // namespace areomap::dem
