#include "ground/dem/KdTree.hpp"

#include <algorithm>

namespace areomap::dem {

namespace {
constexpr int32_t kLeafSize = 12;
constexpr int kMaxDepth = 64;  // explicit stack size of the query (the tree is balanced: depth ~ log2 n)
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
        // Insert sorted.
        int j = found < k ? found++ : k - 1;
        while (j > 0 && dist2[j - 1] > d2) {
          dist2[j] = dist2[j - 1];
          index[j] = index[j - 1];
          --j;
        }
        dist2[j] = d2;
        index[j] = p;
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

}  // namespace areomap::dem
