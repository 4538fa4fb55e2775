#include "ground/dense/SemiGlobal.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>

namespace areomap::dense {

void BandVolume::finishLayout() {
  const std::size_t n = static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols);
  offset.assign(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    offset[i + 1] = offset[i] + count[i];
  }
  cost.assign(static_cast<std::size_t>(offset[n]), 0);
}

namespace {

// The path cost of a disparity that the predecessor's band lacks: above any jump (the predecessor's minimum
// + P2), so it never wins: path costs are normalised by the predecessor's minimum, so a path cost and a jump
// are at most the largest matching cost + P2 (a coarse cell's census sum, 25 x 62, + P2), far below it.
constexpr uint16_t kUnreachable = UINT16_MAX;

struct Direction {
  int dy;
  int dx;
};

// One pass over the image in scan order (forward) or reverse scan order (backward), carrying the path
// costs of up to four directions whose predecessors were already visited.
void runPass(const BandVolume& v, const cv::Mat& guide, const SemiGlobalParams& prm, bool forward,
             const std::vector<Direction>& dirs, std::vector<uint16_t>& sum) {
  const int rows = v.rows;
  const int cols = v.cols;
  int64_t max_row_cells = 0;
  for (int y = 0; y < rows; ++y) {
    const std::size_t a = static_cast<std::size_t>(y) * cols;
    max_row_cells = std::max(max_row_cells, v.offset[a + cols] - v.offset[a]);
  }
  const std::size_t nd = dirs.size();
  std::vector<std::vector<uint16_t>> prev(nd, std::vector<uint16_t>(max_row_cells));
  std::vector<std::vector<uint16_t>> cur(nd, std::vector<uint16_t>(max_row_cells));
  std::vector<std::vector<uint16_t>> prev_min(nd, std::vector<uint16_t>(cols));
  std::vector<std::vector<uint16_t>> cur_min(nd, std::vector<uint16_t>(cols));
  int max_count = 0;
  for (int32_t n : v.count) max_count = std::max(max_count, static_cast<int>(n));
  std::vector<uint16_t> step_buf(static_cast<std::size_t>(max_count) + 2);
  // P2 per grey difference of the neighbours (no division per pixel and path).
  int p2_of_diff[256];
  for (int di = 0; di < 256; ++di) p2_of_diff[di] = std::max(prm.p1 + 1, prm.p2 * 16 / (16 + di));

  for (int iy = 0; iy < rows; ++iy) {
    const int y = forward ? iy : rows - 1 - iy;
    const int py = forward ? y - 1 : y + 1;  // the row visited before this one
    const std::size_t row_base = static_cast<std::size_t>(y) * cols;
    const int64_t row_start = v.offset[row_base];
    const int64_t prow_start = (py >= 0 && py < rows) ? v.offset[static_cast<std::size_t>(py) * cols] : 0;
    const uint8_t* g = guide.ptr<uint8_t>(y);
    const uint8_t* pg = (py >= 0 && py < rows) ? guide.ptr<uint8_t>(py) : nullptr;
    uint16_t* cur_row[4];  // this row's and the previous row's buffers per direction (nd <= 4)
    const uint16_t* prev_row[4];
    uint16_t* cur_row_min[4];
    const uint16_t* prev_row_min[4];
    for (std::size_t k = 0; k < nd; ++k) {
      cur_row[k] = cur[k].data();
      prev_row[k] = prev[k].data();
      cur_row_min[k] = cur_min[k].data();
      prev_row_min[k] = prev_min[k].data();
    }
    for (int ix = 0; ix < cols; ++ix) {
      const int x = forward ? ix : cols - 1 - ix;
      const std::size_t p = row_base + static_cast<std::size_t>(x);
      const int lo = v.lo[p];
      const int n = v.count[p];
      const uint16_t* c = &v.cost[static_cast<std::size_t>(v.offset[p])];
      uint16_t* s = &sum[static_cast<std::size_t>(v.offset[p])];
      const int64_t local = v.offset[p] - row_start;
      for (std::size_t k = 0; k < nd; ++k) {
        const int qy = y + dirs[k].dy;
        const int qx = x + dirs[k].dx;
        uint16_t* out = cur_row[k] + local;
        if (qy < 0 || qy >= rows || qx < 0 || qx >= cols) {
          uint16_t m = UINT16_MAX;
          for (int j = 0; j < n; ++j) {
            const uint16_t cj = c[j];
            out[j] = cj;
            s[j] = static_cast<uint16_t>(s[j] + cj);
            m = std::min(m, cj);
          }
          cur_row_min[k][x] = m;
          continue;
        }
        const std::size_t q = static_cast<std::size_t>(qy) * cols + static_cast<std::size_t>(qx);
        const bool same_row = dirs[k].dy == 0;
        const uint16_t* pl =
            same_row ? cur_row[k] + (v.offset[q] - row_start) : prev_row[k] + (v.offset[q] - prow_start);
        const int pmin = same_row ? cur_row_min[k][qx] : prev_row_min[k][qx];
        const int plo = v.lo[q];
        const int pn = v.count[q];
        const int gq = same_row ? g[qx] : pg[qx];
        const int di = std::abs(static_cast<int>(g[x]) - gq);
        const int p2 = p2_of_diff[di];
        const int jump = pmin + p2;
        // The predecessor's path costs at this pixel's disparities lo - 1 .. lo + n: read in place when its
        // band holds them all, else copied with kUnreachable where it has none. The step below then needs
        // no range test per disparity.
        const int first = plo - lo + 1, last = plo + pn - lo + 1;
        const uint16_t* at;
        if (first <= 0 && last >= n + 2) {
          at = pl + (lo - 1 - plo);
        } else {
          uint16_t* buf = step_buf.data();
          const int f = std::clamp(first, 0, n + 2);
          const int l = std::clamp(last, f, n + 2);
          std::fill(buf, buf + f, kUnreachable);
          for (int i = f; i < l; ++i) buf[i] = pl[i - 1 + lo - plo];
          std::fill(buf + l, buf + n + 2, kUnreachable);
          at = buf;
        }
        const int p1 = prm.p1;
        uint16_t m = UINT16_MAX;
        for (int j = 0; j < n; ++j) {
          const int best = std::min(std::min(jump, static_cast<int>(at[j + 1])),
                                    std::min(static_cast<int>(at[j]), static_cast<int>(at[j + 2])) + p1);
          const uint16_t val = static_cast<uint16_t>(c[j] + best - pmin);
          out[j] = val;
          s[j] = static_cast<uint16_t>(s[j] + val);
          m = std::min(m, val);  // from the register: out may alias s for the compiler
        }
        cur_row_min[k][x] = m;
      }
    }
    std::swap(prev, cur);
    std::swap(prev_min, cur_min);
  }
}

}  // namespace

void aggregateSemiGlobal(const BandVolume& volume, const cv::Mat& guide, const SemiGlobalParams& params,
                         std::vector<uint16_t>& sum) {
  if (guide.type() != CV_8UC1 || guide.rows != volume.rows || guide.cols != volume.cols) {
    throw std::invalid_argument("aggregateSemiGlobal: guide must be CV_8U of the volume's size");
  }
  sum.assign(volume.cost.size(), 0);
  std::vector<Direction> fwd{{0, -1}, {-1, 0}};
  std::vector<Direction> bwd{{0, 1}, {1, 0}};
  if (params.paths >= 8) {
    fwd.push_back({-1, -1});
    fwd.push_back({-1, 1});
    bwd.push_back({1, 1});
    bwd.push_back({1, -1});
  }
  runPass(volume, guide, params, true, fwd, sum);
  runPass(volume, guide, params, false, bwd, sum);
}

}  // namespace areomap::dense
