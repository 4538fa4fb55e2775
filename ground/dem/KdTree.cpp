#include "ground/dem/KdTree.hpp"

#include <algorithm>
#include <cmath>

namespace areomap::dem {

namespace {
constexpr int32_t kLeafSize = 12;
constexpr int kMaxDepth = 64;  // explicit stack size of the query (the tree is balanced: depth ~ log2 n)

// Inserts (d2, id) into the ascending list dist2[0..found) of at most `cap` entries: when full the last one
// drops out; an equal distance goes after the ones already there. Returns the new count.
int insertSorted(double* dist2, int32_t* index, int found, int cap, double d2, int32_t id) {
  int j = found < cap ? found++ : cap - 1;
  while (j > 0 && dist2[j - 1] > d2) {
    dist2[j] = dist2[j - 1];
    index[j] = index[j - 1];
    --j;
  }
  dist2[j] = d2;
  index[j] = id;
  return found;
}
}  // namespace

KdTree2::KdTree2(const std::vector<double>& x, const std::vector<double>& y) : x_(x), y_(y) {
  order_.resize(x_.size());
  for (std::size_t i = 0; i < order_.size(); ++i) order_[i] = static_cast<int32_t>(i);
  nodes_.reserve(2 * (x_.size() / kLeafSize + 1));
  if (!x_.empty()) build(0, static_cast<int32_t>(x_.size()), 0);
  points_.reserve(order_.size());
  for (const int32_t p : order_) points_.push_back(Point{x_[p], y_[p], p});
  // Only points_ is read by the queries.
  std::vector<double>().swap(x_);
  std::vector<double>().swap(y_);
  std::vector<int32_t>().swap(order_);
}

int32_t KdTree2::build(int32_t begin, int32_t end, int depth) {
  const int32_t id = static_cast<int32_t>(nodes_.size());
  nodes_.push_back(Node{begin, end, -1, -1, 0, 0.0});
  if (end - begin <= kLeafSize || depth >= kMaxDepth - 2) return id;
  double minx = 1e300, maxx = -1e300, miny = 1e300, maxy = -1e300;
  for (int32_t i = begin; i < end; ++i) {
    const int32_t p = order_[static_cast<std::size_t>(i)];
    minx = std::min(minx, x_[p]);
    maxx = std::max(maxx, x_[p]);
    miny = std::min(miny, y_[p]);
    maxy = std::max(maxy, y_[p]);
  }
  const int8_t axis = (maxx - minx) >= (maxy - miny) ? 0 : 1;
  const std::vector<double>& c = axis == 0 ? x_ : y_;
  const int32_t mid = begin + (end - begin) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&c](int32_t a, int32_t b) { return c[a] < c[b]; });
  const double split = c[order_[static_cast<std::size_t>(mid)]];
  const int32_t l = build(begin, mid, depth + 1);
  const int32_t r = build(mid, end, depth + 1);
  nodes_[id].left = l;
  nodes_[id].right = r;
  nodes_[id].axis = axis;
  nodes_[id].split = split;
  return id;
}

int KdTree2::nearest(double qx, double qy, int k, int32_t* index, double* dist2, double max_dist2) const {
  if (nodes_.empty() || k <= 0) return 0;
  int found = 0;
  double worst = max_dist2;  // the k-th distance so far (or the bound)
  struct Item {
    int32_t node;
    double d2;  // lower bound of the distance to the node's region
  };
  Item stack[2 * kMaxDepth + 2];
  int top = 0;
  stack[top++] = Item{0, 0.0};
  while (top > 0) {
    const Item it = stack[--top];
    if (it.d2 > worst || (found == k && it.d2 >= worst)) continue;
    const Node& n = nodes_[static_cast<std::size_t>(it.node)];
    if (n.left < 0) {
      for (int32_t i = n.begin; i < n.end; ++i) {
        const Point& pt = points_[static_cast<std::size_t>(i)];
        const int32_t p = pt.index;
        const double dx = pt.x - qx, dy = pt.y - qy;
        const double d2 = dx * dx + dy * dy;
        if (d2 > worst || (found == k && d2 >= worst)) continue;
        found = insertSorted(dist2, index, found, k, d2, p);
        if (found == k) worst = dist2[k - 1];
      }
      continue;
    }
    const double diff = (n.axis == 0 ? qx : qy) - n.split;
    const int32_t near_child = diff < 0 ? n.left : n.right;
    const int32_t far_child = diff < 0 ? n.right : n.left;
    // Far child first on the stack so that the near child is visited first.
    stack[top++] = Item{far_child, std::max(it.d2, diff * diff)};
    stack[top++] = Item{near_child, it.d2};
  }
  return found;
}

PointBuckets::PointBuckets(const std::vector<double>& x, const std::vector<double>& y) {
  const std::size_t n = x.size();
  if (n == 0) return;
  double x1 = x[0], y1 = y[0];
  x0_ = x[0];
  y0_ = y[0];
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(x[i]) || !std::isfinite(y[i])) return;  // no buckets: every query goes to the k-d tree
    x0_ = std::min(x0_, x[i]);
    x1 = std::max(x1, x[i]);
    y0_ = std::min(y0_, y[i]);
    y1 = std::max(y1, y[i]);
  }
  // Square buckets of about kPointsPerBucket points on average (at most ~n / kPointsPerBucket buckets).
  const double w = std::max(x1 - x0_, 1e-9), h = std::max(y1 - y0_, 1e-9);
  const double cell = std::sqrt(w * h * kPointsPerBucket / static_cast<double>(n));
  inv_cell_ = 1.0 / std::max(cell, 1e-9 * std::max(w, h));
  rows_ = static_cast<int>(std::min(w * inv_cell_, 1e6)) + 1;
  cols_ = static_cast<int>(std::min(h * inv_cell_, 1e6)) + 1;
  const auto bucketOf = [&](std::size_t i) {
    const int r = std::min(rows_ - 1, static_cast<int>((x[i] - x0_) * inv_cell_));
    const int c = std::min(cols_ - 1, static_cast<int>((y[i] - y0_) * inv_cell_));
    return static_cast<std::size_t>(r) * static_cast<std::size_t>(cols_) + static_cast<std::size_t>(c);
  };
  start_.assign(static_cast<std::size_t>(rows_) * static_cast<std::size_t>(cols_) + 1, 0);
  for (std::size_t i = 0; i < n; ++i) ++start_[bucketOf(i) + 1];
  for (std::size_t b = 1; b < start_.size(); ++b) start_[b] += start_[b - 1];
  std::vector<int32_t> fill(start_.begin(), start_.end() - 1);
  x_.resize(n);
  y_.resize(n);
  index_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t at = static_cast<std::size_t>(fill[bucketOf(i)]++);
    x_[at] = x[i];
    y_[at] = y[i];
    index_[at] = static_cast<int32_t>(i);
  }
}

int PointBuckets::nearestWithin(double qx, double qy, int k, double max_dist2, int32_t* index,
                                double* dist2) const {
  if (x_.empty() || k <= 0 || k > kMaxBucketNeighbours || !(max_dist2 < 1e300)) return -1;
  // The buckets that hold every point within the bound (a margin of a thousandth of a bucket for rounding).
  const double r = std::sqrt(max_dist2) * inv_cell_ + 1e-3;
  const double rf = (qx - x0_) * inv_cell_, cf = (qy - y0_) * inv_cell_;
  if (!(r < 1e6) || !std::isfinite(rf) || !std::isfinite(cf)) return -1;
  // No bucket within the bound (and the floors below stay within int).
  if (rf + r < 0.0 || cf + r < 0.0 || rf - r > rows_ || cf - r > cols_) return -1;
  const int r0 = std::max(0, static_cast<int>(std::floor(rf - r))),
            r1 = std::min(rows_ - 1, static_cast<int>(std::floor(rf + r)));
  const int c0 = std::max(0, static_cast<int>(std::floor(cf - r))),
            c1 = std::min(cols_ - 1, static_cast<int>(std::floor(cf + r)));
  if (r0 > r1 || c0 > c1) return -1;
  int to_read = 0;
  for (int row = r0; row <= r1; ++row) {
    const std::size_t b = static_cast<std::size_t>(row) * static_cast<std::size_t>(cols_);
    to_read += start_[b + static_cast<std::size_t>(c1) + 1] - start_[b + static_cast<std::size_t>(c0)];
    if (to_read > kMaxPointsRead) return -1;
  }
  // The k + 1 nearest within the bound, by insertion (one more than asked, to see a tie at the k-th).
  const int keep = k + 1;
  int found = 0;
  double d[kMaxBucketNeighbours + 1];
  int32_t at[kMaxBucketNeighbours + 1];
  double worst = max_dist2;
  for (int row = r0; row <= r1; ++row) {
    const std::size_t b = static_cast<std::size_t>(row) * static_cast<std::size_t>(cols_);
    const int32_t end = start_[b + static_cast<std::size_t>(c1) + 1];
    for (int32_t i = start_[b + static_cast<std::size_t>(c0)]; i < end; ++i) {
      // The same expression as KdTree2::nearest, so the same distances bit for bit.
      const double dx = x_[static_cast<std::size_t>(i)] - qx, dy = y_[static_cast<std::size_t>(i)] - qy;
      const double d2 = dx * dx + dy * dy;
      if (d2 > worst) continue;
      found = insertSorted(d, at, found, keep, d2, i);
      if (found == keep) worst = d[keep - 1];
    }
  }
  if (found < k) return -1;
  for (int i = 1; i < found; ++i)
    if (!(d[i - 1] < d[i])) return -1;  // a tie (or NaN): the k-d tree's search order decides
  for (int i = 0; i < k; ++i) {
    index[i] = index_[static_cast<std::size_t>(at[i])];
    dist2[i] = d[i];
  }
  return k;
}

}  // namespace areomap::dem
