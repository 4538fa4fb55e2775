#include "ground/dense/FineBand.hpp"

#include <algorithm>
#include <cstdint>

#include <opencv2/imgproc.hpp>

namespace areomap::dense {

namespace {

inline uint16_t censusDistance(uint64_t a, uint64_t b) {
  return static_cast<uint16_t>(__builtin_popcountll(a ^ b));
}

// The fine costs of a one-pixel block (fineCosts): each pixel's own census distance at each disparity of its
// band, straight into the volume.
void pixelCosts(const cv::Mat& cl, const cv::Mat& cr, const std::vector<uint8_t>& no_band, BandVolume& v) {
  const int cols = v.cols;
  for (int y = 0; y < v.rows; ++y) {
    const uint64_t* a = cl.ptr<uint64_t>(y);
    const uint64_t* b = cr.ptr<uint64_t>(y);
    for (int x = 0; x < cols; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * cols + x;
      uint16_t* c = &v.cost[static_cast<std::size_t>(v.offset[p])];
      const int n = v.count[p];
      if (no_band[p]) {
        std::fill(c, c + n, kCensusNoMatchCost);
        continue;
      }
      // xr = x - lo - j lies in [0, cols) for j in [x - lo - cols + 1, x - lo].
      const int xr0 = x - v.lo[p];
      const int j_begin = std::clamp(xr0 - cols + 1, 0, n);
      const int j_end = std::clamp(xr0 + 1, j_begin, n);
      const uint64_t ca = a[x];
      std::fill(c, c + j_begin, kCensusNoMatchCost);
      for (int j = j_begin; j < j_end; ++j) c[j] = censusDistance(ca, b[xr0 - j]);
      std::fill(c + j_end, c + n, kCensusNoMatchCost);
    }
  }
}

}  // namespace

BandVolume fineBand(const cv::Mat& coarse, int rows, int cols, const DenseOptions& o, const cv::Mat& mask,
                    std::vector<uint8_t>& no_band) {
  const int step = o.coarse_step_px;
  const int off = step / 2;
  cv::Mat cmin, cmax;
  const cv::Mat kernel = cv::Mat::ones(4, 4, CV_8UC1);
  cv::erode(coarse, cmin, kernel, cv::Point(1, 1), 1, cv::BORDER_REPLICATE);
  cv::dilate(coarse, cmax, kernel, cv::Point(1, 1), 1, cv::BORDER_REPLICATE);
  BandVolume v;
  v.rows = rows;
  v.cols = cols;
  v.lo.resize(static_cast<std::size_t>(rows) * cols);
  v.count.resize(v.lo.size());
  no_band.assign(v.lo.size(), 0);
  std::vector<int> gx_of_x(static_cast<std::size_t>(cols));  // the grid column of each image column
  for (int x = 0; x < cols; ++x)
    gx_of_x[x] = std::clamp((x - off) / step - (x < off ? 1 : 0), 0, coarse.cols - 1);
  for (int y = 0; y < rows; ++y) {
    const int gy = std::clamp((y - off) / step - (y < off ? 1 : 0), 0, coarse.rows - 1);
    const float* min_row = cmin.ptr<float>(gy);
    const float* max_row = cmax.ptr<float>(gy);
    const uint8_t* mask_row = mask.empty() ? nullptr : mask.ptr<uint8_t>(y);
    for (int x = 0; x < cols; ++x) {
      const int gx = gx_of_x[x];
      const std::size_t p = static_cast<std::size_t>(y) * cols + x;
      int lo = static_cast<int>(min_row[gx]) - o.fine_margin_px;
      int hi = static_cast<int>(max_row[gx]) + o.fine_margin_px;
      lo = std::max(lo, o.min_disparity_px);
      hi = std::min({hi, o.max_disparity_px, x});
      if (hi < lo || (mask_row != nullptr && mask_row[x] == 0)) {
        no_band[p] = 1;
        hi = lo;
      }
      v.lo[p] = lo;
      v.count[p] = hi - lo + 1;
    }
  }
  v.finishLayout();
  return v;
}

void fineCosts(const cv::Mat& cl, const cv::Mat& cr, const std::vector<uint8_t>& no_band, int block_half_px,
               BandVolume& v) {
  if (block_half_px == 0) {
    pixelCosts(cl, cr, no_band, v);
    return;
  }
  const int rows = v.rows, cols = v.cols, h = block_half_px;
  const int area = (2 * h + 1) * (2 * h + 1);
  std::vector<int> ext_lo(static_cast<std::size_t>(cols)), ext_hi(static_cast<std::size_t>(cols));
  std::vector<std::size_t> ext_at(static_cast<std::size_t>(cols) + 1);
  std::vector<int> col_sum, acc;
  std::vector<const uint64_t*> a(static_cast<std::size_t>(2 * h + 1)), b(a.size());
  for (int y = 0; y < rows; ++y) {
    const std::size_t row = static_cast<std::size_t>(y) * cols;
    for (int k = -h; k <= h; ++k) {
      const int yy = std::clamp(y + k, 0, rows - 1);
      a[static_cast<std::size_t>(k + h)] = cl.ptr<uint64_t>(yy);
      b[static_cast<std::size_t>(k + h)] = cr.ptr<uint64_t>(yy);
    }
    // The disparities each column's V is needed at (empty: lo > hi).
    ext_at[0] = 0;
    for (int xc = 0; xc < cols; ++xc) {
      int lo = INT32_MAX, hi = INT32_MIN;
      for (int x = std::max(0, xc - h); x <= std::min(cols - 1, xc + h); ++x) {
        if (no_band[row + x]) continue;
        lo = std::min(lo, v.lo[row + x]);
        hi = std::max(hi, v.lo[row + x] + v.count[row + x] - 1);
      }
      ext_lo[xc] = lo;
      ext_hi[xc] = hi;
      ext_at[xc + 1] = ext_at[xc] + static_cast<std::size_t>(hi >= lo ? hi - lo + 1 : 0);
    }
    col_sum.resize(ext_at[cols]);
    for (int xc = 0; xc < cols; ++xc) {
      if (ext_hi[xc] < ext_lo[xc]) continue;  // no pixel's block needs this column
      int* vs = &col_sum[ext_at[xc]];
      const int n = ext_hi[xc] - ext_lo[xc] + 1;
      std::fill(vs, vs + n, 0);
      // xr = xc - ext_lo - j lies in [0, cols) for j in [xc - ext_lo - cols + 1, xc - ext_lo].
      const int xr0 = xc - ext_lo[xc];
      const int j_begin = std::clamp(xr0 - cols + 1, 0, n);
      const int j_end = std::clamp(xr0 + 1, j_begin, n);
      for (int k = 0; k <= 2 * h; ++k) {
        const uint64_t ca = a[static_cast<std::size_t>(k)][xc];
        const uint64_t* bk = b[static_cast<std::size_t>(k)];
        for (int j = j_begin; j < j_end; ++j) vs[j] += censusDistance(ca, bk[xr0 - j]);
      }
      for (int j = 0; j < j_begin; ++j) vs[j] = (2 * h + 1) * kCensusNoMatchCost;
      for (int j = j_end; j < n; ++j) vs[j] = (2 * h + 1) * kCensusNoMatchCost;
    }
    for (int x = 0; x < cols; ++x) {
      const std::size_t p = row + x;
      uint16_t* c = &v.cost[static_cast<std::size_t>(v.offset[p])];
      const int n = v.count[p], lo = v.lo[p];
      if (no_band[p]) {
        std::fill(c, c + n, kCensusNoMatchCost);
        continue;
      }
      acc.assign(static_cast<std::size_t>(n), 0);
      for (int k = -h; k <= h; ++k) {
        const int xc = std::clamp(x + k, 0, cols - 1);
        const int* vs = &col_sum[ext_at[xc]] + (lo - ext_lo[xc]);
        for (int j = 0; j < n; ++j) acc[static_cast<std::size_t>(j)] += vs[j];
      }
      for (int j = 0; j < n; ++j)
        c[j] = static_cast<uint16_t>((acc[static_cast<std::size_t>(j)] + area / 2) / area);
    }
  }
}

}  // namespace areomap::dense
