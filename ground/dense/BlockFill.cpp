#include "ground/dense/BlockFill.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace areomap::dense {

namespace {

// The right view's cost of a left pixel beyond the image: never a winner.
constexpr int kOutside = std::numeric_limits<int>::max() / 2;

// The census distances summed over the block about (x, y), every p.stride_px-th pixel (sample columns and
// rows clamped to the image; a right pixel outside it costs no_match_cost), at disparities lo .. lo + n - 1
// into c. Per block sample, the loop over the disparities has no branch.
// Where every sample's right pixels lie inside the image at every disparity (the block away from the image's
// left and right edges), the samples are gathered first and each disparity's cost is one branch-free sum
// over them.
void blockCosts(const cv::Mat& cl, const cv::Mat& cr, int x, int y, int lo, int n, const BlockFillParams& p,
                int* c) {
  const int h = p.block_half_px, s = p.stride_px, cols = cl.cols;
  if (x - h >= 0 && x + h < cols && x - h - lo - (n - 1) >= 0 && x + h - lo < cols) {
    thread_local std::vector<uint64_t> left;
    thread_local std::vector<const uint64_t*> right;  // the right pixel of each sample at j = 0
    left.clear();
    right.clear();
    for (int dy = -h; dy <= h; dy += s) {
      const int yy = std::clamp(y + dy, 0, cl.rows - 1);
      const uint64_t* a = cl.ptr<uint64_t>(yy);
      const uint64_t* b = cr.ptr<uint64_t>(yy);
      for (int dx = -h; dx <= h; dx += s) {
        left.push_back(a[x + dx]);
        right.push_back(b + x + dx - lo);
      }
    }
    const std::size_t samples = left.size();
    for (int j = 0; j < n; ++j) {
      int sum = 0;
      for (std::size_t k = 0; k < samples; ++k) sum += __builtin_popcountll(left[k] ^ right[k][-j]);
      c[j] = sum;
    }
    return;
  }
  std::fill(c, c + n, 0);
  for (int dy = -h; dy <= h; dy += s) {
    const int yy = std::clamp(y + dy, 0, cl.rows - 1);
    const uint64_t* a = cl.ptr<uint64_t>(yy);
    const uint64_t* b = cr.ptr<uint64_t>(yy);
    for (int dx = -h; dx <= h; dx += s) {
      const int xl = std::clamp(x + dx, 0, cols - 1);
      const uint64_t ca = a[xl];
      // xr = xl - lo - j lies in [0, cols) for j in [xl - lo - cols + 1, xl - lo].
      const int j_begin = std::clamp(xl - lo - cols + 1, 0, n);
      const int j_end = std::clamp(xl - lo + 1, j_begin, n);
      const int xr0 = xl - lo;
      for (int j = 0; j < j_begin; ++j) c[j] += p.no_match_cost;
      for (int j = j_begin; j < j_end; ++j) c[j] += __builtin_popcountll(ca ^ b[xr0 - j]);
      for (int j = j_end; j < n; ++j) c[j] += p.no_match_cost;
    }
  }
}

// The right view's block costs at right pixel xr: c[j] = the block sum (as blockCosts) of left pixel
// xr + lo + j at disparity lo + j (kOutside where that pixel lies beyond the image). Away from the image's
// borders the block's right pixels are fixed and its left ones contiguous along j: that loop has no branch.
void rightBlockCosts(const cv::Mat& cl, const cv::Mat& cr, int xr, int y, int lo, int n,
                     const BlockFillParams& p, int* c) {
  const int h = p.block_half_px, s = p.stride_px, cols = cl.cols;
  const int n_in = std::clamp(cols - xr - lo, 0, n);
  std::fill(c, c + n_in, 0);
  std::fill(c + n_in, c + n, kOutside);
  for (int dy = -h; dy <= h; dy += s) {
    const int yy = std::clamp(y + dy, 0, cl.rows - 1);
    const uint64_t* a = cl.ptr<uint64_t>(yy);
    const uint64_t* b = cr.ptr<uint64_t>(yy);
    for (int dx = -h; dx <= h; dx += s) {
      const int x0 = xr + lo + dx;  // the left pixel at j = 0
      if (xr + dx >= 0 && xr + dx < cols && x0 >= 0 && x0 + n_in - 1 < cols) {
        const uint64_t cb = b[xr + dx];
        for (int j = 0; j < n_in; ++j) c[j] += __builtin_popcountll(a[x0 + j] ^ cb);
        continue;
      }
      for (int j = 0; j < n_in; ++j) {
        const int xl = std::clamp(x0 + j, 0, cols - 1), xr2 = xl - lo - j;
        c[j] += (xr2 >= 0 && xr2 < cols) ? __builtin_popcountll(a[xl] ^ b[xr2]) : p.no_match_cost;
      }
    }
  }
}

// Parabola sub-pixel offset of the minimum at index `best` of `c` (n values); 0 at the band's ends.
double parabola(const int* c, int best, int n) {
  if (best <= 0 || best + 1 >= n) return 0.0;
  const double denom = static_cast<double>(c[best - 1]) + c[best + 1] - 2.0 * c[best];
  return denom > 0.0 ? (static_cast<double>(c[best - 1]) - c[best + 1]) / (2.0 * denom) : 0.0;
}

int argmin(const int* c, int n) {
  int best = 0;
  for (int j = 1; j < n; ++j)
    if (c[j] < c[best]) best = j;
  return best;
}

// The left view's block winner at (x, y) over its band (costs into `left`): its index in the band, or -1
// where it fails a test (no minimum inside the band, cost above chance, not unique).
int leftBlockWinner(const cv::Mat& cl, const cv::Mat& cr, const BandVolume& v, int x, int y,
                    const BlockFillParams& p, std::vector<int>& left) {
  const int side = 2 * (p.block_half_px / p.stride_px) + 1;  // samples along each side
  const std::size_t px = static_cast<std::size_t>(y) * v.cols + x;
  const int lo = v.lo[px], n = v.count[px];
  if (n < 3) return -1;  // no minimum inside the band
  left.resize(static_cast<std::size_t>(n));
  blockCosts(cl, cr, x, y, lo, n, p, left.data());
  const int best = argmin(left.data(), n);
  if (best == 0 || best == n - 1) return -1;  // the minimum lies at or beyond the band's end
  if (left[best] > p.max_census_cost_bits * side * side) return -1;
  for (int j = 0; j < n; ++j)
    if (std::abs(j - best) > 1 && left[j] * (100 - p.uniqueness_percent) <= left[best] * 100) return -1;
  return best;
}

}  // namespace

long long blockFill(const cv::Mat& cl, const cv::Mat& cr, const BandVolume& v, const cv::Mat& candidate,
                    const BlockFillParams& p, cv::Mat& disparity, cv::Mat& valid, cv::Mat& block,
                    cv::Mat& lr_diff_px) {
  std::vector<int> left, right;
  long long filled = 0;
  for (int y = 0; y < v.rows; ++y) {
    const uint8_t* cand = candidate.ptr<uint8_t>(y);
    for (int x = 0; x < v.cols; ++x) {
      if (!cand[x]) continue;
      const int best = leftBlockWinner(cl, cr, v, x, y, p, left);
      if (best < 0) continue;
      const std::size_t px = static_cast<std::size_t>(y) * v.cols + x;
      const int lo = v.lo[px], n = v.count[px];
      // The right view at the matched pixel: its block winner over the same disparities.
      const int xr = x - (lo + best);
      right.resize(static_cast<std::size_t>(n));
      rightBlockCosts(cl, cr, xr, y, lo, n, p, right.data());
      const int rbest = argmin(right.data(), n);
      if (std::abs(rbest - best) > p.lr_max_diff_px) continue;
      const float d = static_cast<float>(lo + best + parabola(left.data(), best, n));
      disparity.at<float>(y, x) = d;
      valid.at<uint8_t>(y, x) = 255;
      block.at<uint8_t>(y, x) = 255;
      if (rbest > 0 && rbest + 1 < n && right[rbest - 1] < kOutside && right[rbest + 1] < kOutside)
        lr_diff_px.at<float>(y, x) = d - static_cast<float>(lo + rbest + parabola(right.data(), rbest, n));
      ++filled;
    }
  }
  return filled;
}

void blockCheck(const cv::Mat& cl, const cv::Mat& cr, const BandVolume& v, const cv::Mat& valid,
                const cv::Mat& disparity, int every_px, const BlockFillParams& p, cv::Mat& check_px) {
  check_px = cv::Mat(v.rows, v.cols, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  std::vector<int> left;
  for (int y = every_px / 2; y < v.rows; y += every_px) {
    for (int x = every_px / 2; x < v.cols; x += every_px) {
      if (!valid.at<uint8_t>(y, x)) continue;
      const int best = leftBlockWinner(cl, cr, v, x, y, p, left);
      if (best < 0) continue;
      const int lo = v.lo[static_cast<std::size_t>(y) * v.cols + x];
      const double d = lo + best + parabola(left.data(), best, static_cast<int>(left.size()));
      check_px.at<float>(y, x) = static_cast<float>(d - disparity.at<float>(y, x));
    }
  }
}

}  // namespace areomap::dense
