#include "firmware_core/match/ForstnerDetector.hpp"

#include <cmath>

namespace areomap {
namespace {

// cell_best holds the cells of a full-size frame at 16 px; smaller cells are allowed where the cell count fits
// (a small frame at 1/32 of its side).
constexpr int32_t kMaxCells = (kMaxImageWidth / 16) * (kMaxImageHeight / 16);

// Integer gradient products of one line (gx2 = (I(x+1)-I(x-1))^2 etc., i.e. (2 g)^2), 0 at the borders.
void gradientProducts(const ImageView& image, int32_t y, int32_t* gxx, int32_t* gxy, int32_t* gyy) {
  const int32_t w = image.width;
  for (int32_t x = 0; x < w; ++x) {
    gxx[x] = 0;
    gxy[x] = 0;
    gyy[x] = 0;
  }
  if (y < 1 || y > image.height - 2) return;
  const uint8_t* up = image.row(y - 1);
  const uint8_t* mid = image.row(y);
  const uint8_t* down = image.row(y + 1);
  for (int32_t x = 1; x < w - 1; ++x) {
    const int32_t gx = static_cast<int32_t>(mid[x + 1]) - static_cast<int32_t>(mid[x - 1]);
    const int32_t gy = static_cast<int32_t>(down[x]) - static_cast<int32_t>(up[x]);
    gxx[x] = gx * gx;
    gxy[x] = gx * gy;
    gyy[x] = gy * gy;
  }
}

// Förstner's least-squares corner in the (2r+1)^2 window of (x, y): argmin sum (g . (q - p))^2 over the
// window's gradients g at pixels p. False when singular or farther than r from (x, y).
bool leastSquaresCorner(const ImageView& image, int32_t x, int32_t y, int32_t r, double& cx, double& cy) {
  double nxx = 0.0, nxy = 0.0, nyy = 0.0, bx = 0.0, by = 0.0;
  for (int32_t v = y - r; v <= y + r; ++v) {
    for (int32_t u = x - r; u <= x + r; ++u) {
      const double gx = 0.5 * (static_cast<double>(image.at(u + 1, v)) - static_cast<double>(image.at(u - 1, v)));
      const double gy = 0.5 * (static_cast<double>(image.at(u, v + 1)) - static_cast<double>(image.at(u, v - 1)));
      nxx += gx * gx;
      nxy += gx * gy;
      nyy += gy * gy;
      const double gp = gx * (u - x) + gy * (v - y);  // relative to (x, y) for conditioning
      bx += gx * gp;
      by += gy * gp;
    }
  }
  const double det = nxx * nyy - nxy * nxy;
  const double trace = nxx + nyy;
  if (!(trace > 0.0) || det <= 1e-9 * trace * trace) return false;
  const double dx = (nyy * bx - nxy * by) / det;
  const double dy = (nxx * by - nxy * bx) / det;
  if (std::fabs(dx) > r || std::fabs(dy) > r) return false;
  cx = x + dx;
  cy = y + dy;
  return true;
}

}  // namespace

Status computeForstnerMaps(const ImageView& image, const ForstnerParams& params,
                           ForstnerWorkspace& workspace) {
  if (!image.valid() || params.window_radius < 1 || params.window_radius > kMaxForstnerRadius) {
    return Status::kInvalidArgument;
  }
  if (image.width > kMaxImageWidth || image.height > kMaxImageHeight) return Status::kCapacityExceeded;
  const int32_t w = image.width;
  const int32_t h = image.height;
  const int32_t r = params.window_radius;
  const int32_t side = 2 * r + 1;
  workspace.width = w;
  workspace.height = h;
  for (int32_t i = 0; i < w * h; ++i) {
    workspace.weight[i] = 0.0f;
    workspace.roundness[i] = 0.0f;
  }
  for (int32_t c = 0; c < 3; ++c) {
    for (int32_t x = 0; x < w; ++x) workspace.column_sum[c][x] = 0;
  }
  // Row y of the image enters the ring at slot y % side; the window of centre line yc = y - r is complete
  // once line y has entered. Products are 0 on the image border lines, so the window sum of a centre line
  // is exact wherever its window lies inside lines 1..h-2 (we only write centres with r+1 <= yc <= h-r-2).
  for (int32_t y = 0; y < h; ++y) {
    const int32_t slot = y % side;
    for (int32_t c = 0; c < 3; ++c) {
      if (y >= side) {
        for (int32_t x = 0; x < w; ++x) workspace.column_sum[c][x] -= workspace.ring[c][slot][x];
      }
    }
    gradientProducts(image, y, workspace.ring[0][slot], workspace.ring[1][slot], workspace.ring[2][slot]);
    for (int32_t c = 0; c < 3; ++c) {
      for (int32_t x = 0; x < w; ++x) workspace.column_sum[c][x] += workspace.ring[c][slot][x];
    }
    const int32_t yc = y - r;
    if (yc < r + 1 || yc > h - r - 2) continue;
    // Horizontal running sum of the column sums.
    int64_t sxx = 0, sxy = 0, syy = 0;
    for (int32_t x = 0; x < side - 1; ++x) {
      sxx += workspace.column_sum[0][x];
      sxy += workspace.column_sum[1][x];
      syy += workspace.column_sum[2][x];
    }
    for (int32_t xc = r; xc < w - r; ++xc) {
      const int32_t x_in = xc + r;
      sxx += workspace.column_sum[0][x_in];
      sxy += workspace.column_sum[1][x_in];
      syy += workspace.column_sum[2][x_in];
      if (xc >= r + 1 && xc <= w - r - 2) {
        // Sums are of (2g)^2: N = sums / 4.
        const double nxx = 0.25 * static_cast<double>(sxx);
        const double nxy = 0.25 * static_cast<double>(sxy);
        const double nyy = 0.25 * static_cast<double>(syy);
        const double trace = nxx + nyy;
        if (trace > 0.0) {
          const double det = nxx * nyy - nxy * nxy;
          const int32_t idx = yc * w + xc;
          workspace.weight[idx] = static_cast<float>(det / trace);
          workspace.roundness[idx] = static_cast<float>(4.0 * det / (trace * trace));
        }
      }
      const int32_t x_out = xc - r;
      sxx -= workspace.column_sum[0][x_out];
      sxy -= workspace.column_sum[1][x_out];
      syy -= workspace.column_sum[2][x_out];
    }
  }
  return Status::kOk;
}

Status detectInterestPoints(const ImageView& image, const ForstnerParams& params, ForstnerWorkspace& workspace,
                            InterestPoint* points, int32_t capacity, int32_t& count) {
  count = 0;
  if (points == nullptr || capacity < 0 || params.nms_radius < 1 || params.nms_radius > kMaxForstnerRadius ||
      params.cell_px < kMinSpreadingCellPx || params.max_per_cell < 1 ||
      params.max_per_cell > kMaxInterestPointsPerCell || params.border_px < 0) {
    return Status::kInvalidArgument;
  }
  const Status maps = computeForstnerMaps(image, params, workspace);
  if (!ok(maps)) return maps;
  const int32_t w = image.width;
  const int32_t h = image.height;
  const float* wm = workspace.weight;
  const float* qm = workspace.roundness;

  // Threshold: a multiple of the mean w over the defined interior, never below the absolute floor.
  double sum_w = 0.0;
  int64_t defined = 0;
  const int32_t edge = params.window_radius + 1;
  for (int32_t y = edge; y < h - edge; ++y) {
    for (int32_t x = edge; x < w - edge; ++x) {
      sum_w += wm[y * w + x];
      ++defined;
    }
  }
  const double mean_w = defined > 0 ? sum_w / static_cast<double>(defined) : 0.0;
  const double w_threshold = std::fmax(params.w_min, params.w_mean_factor * mean_w);

  const int32_t cells_x = (w + params.cell_px - 1) / params.cell_px;
  const int32_t cells_y = (h + params.cell_px - 1) / params.cell_px;
  const int32_t cells = cells_x * cells_y;
  if (cells > kMaxCells) return Status::kCapacityExceeded;
  for (int32_t c = 0; c < cells; ++c) workspace.cell_count[c] = 0;

  // Candidates need w defined (edge), their NMS neighbourhood in the image (n) and the caller's border; these
  // are distances from the same image border, so the margin is the largest of them, not their sum (a narrow
  // overlap at the border keeps its points).
  const int32_t n = params.nms_radius;
  int32_t margin = edge > n ? edge : n;
  if (params.border_px > margin) margin = params.border_px;
  for (int32_t y = margin; y < h - margin; ++y) {
    for (int32_t x = margin; x < w - margin; ++x) {
      const float v = wm[y * w + x];
      if (v <= w_threshold || qm[y * w + x] <= params.q_min) continue;
      // Strict maximum over earlier pixels, >= over later ones: exactly one pixel wins a plateau.
      bool is_max = true;
      for (int32_t dy = -n; dy <= n && is_max; ++dy) {
        const float* row = wm + (y + dy) * w;
        for (int32_t dx = -n; dx <= n; ++dx) {
          if (dx == 0 && dy == 0) continue;
          const float o = row[x + dx];
          const bool earlier = dy < 0 || (dy == 0 && dx < 0);
          if (earlier ? o >= v : o > v) {
            is_max = false;
            break;
          }
        }
      }
      if (!is_max) continue;
      // Sub-pixel: the operator's own least-squares corner, the point closest to all edge lines of the
      // window (N^-1 sum(g g^T p)); the parabola vertex of w when that falls outside the window.
      InterestPoint p;
      double sx = 0.0, sy = 0.0;
      if (!leastSquaresCorner(image, x, y, params.window_radius, sx, sy)) {
        const double wl = wm[y * w + x - 1], wr = wm[y * w + x + 1];
        const double wu = wm[(y - 1) * w + x], wd = wm[(y + 1) * w + x];
        const double cx = wl - 2.0 * v + wr;
        const double cy = wu - 2.0 * v + wd;
        sx = x + (cx < 0.0 ? std::fmax(-0.5, std::fmin(0.5, 0.5 * (wl - wr) / cx)) : 0.0);
        sy = y + (cy < 0.0 ? std::fmax(-0.5, std::fmin(0.5, 0.5 * (wu - wd) / cy)) : 0.0);
      }
      p.x_px = static_cast<float>(sx);
      p.y_px = static_cast<float>(sy);
      p.pixel_x = x;
      p.pixel_y = y;
      p.weight = v;
      p.roundness = qm[y * w + x];
      // Insert into the cell's best list (sorted by weight, descending).
      const int32_t cell = (y / params.cell_px) * cells_x + (x / params.cell_px);
      InterestPoint* best = workspace.cell_best[cell];
      int32_t& k = workspace.cell_count[cell];
      int32_t pos = k;
      while (pos > 0 && best[pos - 1].weight < p.weight) --pos;
      if (pos >= params.max_per_cell) continue;
      const int32_t last = k < params.max_per_cell ? k : params.max_per_cell - 1;
      for (int32_t i = last; i > pos; --i) best[i] = best[i - 1];
      best[pos] = p;
      if (k < params.max_per_cell) ++k;
    }
  }
  int32_t total = 0;
  for (int32_t c = 0; c < cells; ++c) total += workspace.cell_count[c];
  if (total > capacity) return Status::kCapacityExceeded;
  for (int32_t c = 0; c < cells; ++c) {
    for (int32_t i = 0; i < workspace.cell_count[c]; ++i) points[count++] = workspace.cell_best[c][i];
  }
  return count < params.min_points ? Status::kNoTexture : Status::kOk;
}

}  // namespace areomap
