#include "ground/dense/DenseMatcher.hpp"

#include "ground/dense/BlockFill.hpp"
#include "ground/dense/FineBand.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace areomap::dense {

namespace {

constexpr int kCensusHalfWidth = kCensusWindowCols / 2;
constexpr int kCensusHalfHeight = kCensusWindowRows / 2;
constexpr int kCensusBits = (2 * kCensusHalfWidth + 1) * (2 * kCensusHalfHeight + 1) - 1;  // 62
constexpr uint16_t kNoMatchCost = kCensusNoMatchCost;
static_assert(kNoMatchCost == kCensusBits, "a right pixel outside the image differs in every census bit");
// Holes are filled from the nearest valid pixels at most this far away (pixels).
constexpr int kMaxFillReachPx = 64;

double seconds() {
  return static_cast<double>(cv::getTickCount()) / cv::getTickFrequency();
}

const uint64_t* censusRow(const cv::Mat& census, int y) {
  return census.ptr<uint64_t>(y);
}

inline uint16_t hamming(uint64_t a, uint64_t b) {
  return static_cast<uint16_t>(__builtin_popcountll(a ^ b));
}

// Winner-takes-all over one pixel's band: the index of its first minimum (without a branch per candidate:
// which one wins is the data's, and a mispredicted branch costs more than the comparison).
int argminCost(const uint16_t* s, int n) {
  int best = 0, min_s = s[0];
  for (int j = 1; j < n; ++j) {
    const bool lower = s[j] < min_s;
    best = lower ? j : best;
    min_s = lower ? s[j] : min_s;
  }
  return best;
}

// The uniqueness test: the minimum at `best` beats every candidate more than one disparity away by
// uniqueness_percent.
bool uniqueMinimum(const uint16_t* s, int n, int best, int uniqueness_percent) {
  const int min_s = s[best];
  for (int j = 0; j < n; ++j) {
    if (std::abs(j - best) > 1 && s[j] * (100 - uniqueness_percent) <= min_s * 100) return false;
  }
  return true;
}

// The winner's sub-pixel disparity: the parabola through its costs and its neighbours' (none at the band's
// ends or where they are flat).
float parabolaDisparity(const uint16_t* s, int lo, int n, int best) {
  double sub = 0.0;
  if (best > 0 && best + 1 < n) {
    const double denom = static_cast<double>(s[best - 1]) + s[best + 1] - 2.0 * s[best];
    if (denom > 0.0) sub = (static_cast<double>(s[best - 1]) - s[best + 1]) / (2.0 * denom);
  }
  return static_cast<float>(lo + best + sub);
}

void checkInput(const cv::Mat& left, const cv::Mat& right, const DenseOptions& o) {
  if (left.empty() || right.empty()) throw std::invalid_argument("dense matching: empty image");
  if (left.type() != CV_8UC1 || right.type() != CV_8UC1) {
    throw std::invalid_argument("dense matching: images must be 8-bit grey");
  }
  if (left.size() != right.size()) throw std::invalid_argument("dense matching: image sizes differ");
  if (o.max_disparity_px < o.min_disparity_px) {
    throw std::invalid_argument("dense matching: max disparity below min disparity");
  }
  if (o.coarse_step_px < 1) throw std::invalid_argument("dense matching: coarse step < 1");
  if (o.fine_block_px < 1 || o.fine_block_px % 2 == 0) {
    throw std::invalid_argument("dense matching: fine block must be odd and positive");
  }
  if (o.fill_block_px < 0 || (o.fill_block_px > 0 && o.fill_block_px % 2 == 0)) {
    throw std::invalid_argument("dense matching: fill block must be 0 (off) or odd and positive");
  }
  if (left.cols < 2 * o.coarse_step_px || left.rows < 2 * o.coarse_step_px) {
    throw std::invalid_argument("dense matching: image smaller than two coarse cells");
  }
}

// Coarse pass on the step-px grid: returns the coarse disparity per node (CV_32F).
cv::Mat coarsePass(const cv::Mat& left, const cv::Mat& cl, const cv::Mat& cr, const DenseOptions& o,
                   const std::vector<RowRange>& ranges) {
  const int step = o.coarse_step_px;
  const int off = step / 2;
  const int gh = (left.rows - 1 - off) / step + 1;
  const int gw = (left.cols - 1 - off) / step + 1;
  BandVolume v;
  v.rows = gh;
  v.cols = gw;
  v.lo.resize(static_cast<std::size_t>(gh) * gw);
  v.count.resize(v.lo.size());
  for (int gy = 0; gy < gh; ++gy) {
    const RowRange r = ranges[static_cast<std::size_t>(off + gy * step)];
    for (int gx = 0; gx < gw; ++gx) {
      const int x = off + gx * step;
      const std::size_t p = static_cast<std::size_t>(gy) * gw + gx;
      const int hi = std::min(r.hi, x);
      v.lo[p] = std::min(r.lo, hi);
      v.count[p] = hi - v.lo[p] + 1;
    }
  }
  v.finishLayout();
  const int half = step / 2;
  const int area = (2 * half + 1) * (2 * half + 1);
  // Per node, the window's Hamming distances are summed disparity by disparity with the window pixel fixed
  // (the inner loop over disparities has no branch: the disparities whose right pixel lies outside the image
  // take kNoMatchCost in bulk). The same integer sums as pixel by pixel per disparity.
  std::vector<int> total;
  for (int gy = 0; gy < gh; ++gy) {
    const int y = off + gy * step;
    for (int gx = 0; gx < gw; ++gx) {
      const int x = off + gx * step;
      const std::size_t p = static_cast<std::size_t>(gy) * gw + gx;
      const int lo = v.lo[p], n = v.count[p];
      total.assign(static_cast<std::size_t>(n), 0);
      int* t = total.data();
      for (int dy = -half; dy <= half; ++dy) {
        const int yy = std::clamp(y + dy, 0, left.rows - 1);
        const uint64_t* a = censusRow(cl, yy);
        const uint64_t* b = censusRow(cr, yy);
        for (int dx = -half; dx <= half; ++dx) {
          const int xl = std::clamp(x + dx, 0, left.cols - 1);
          const uint64_t ca = a[xl];
          // xr = xl - lo - j lies in [0, cols) for j in [xl - lo - cols + 1, xl - lo].
          const int j_begin = std::clamp(xl - lo - left.cols + 1, 0, n);
          const int j_end = std::clamp(xl - lo + 1, j_begin, n);
          for (int j = 0; j < j_begin; ++j) t[j] += kNoMatchCost;
          const int xr0 = xl - lo;
          for (int j = j_begin; j < j_end; ++j) t[j] += hamming(ca, b[xr0 - j]);
          for (int j = j_end; j < n; ++j) t[j] += kNoMatchCost;
        }
      }
      uint16_t* c = &v.cost[static_cast<std::size_t>(v.offset[p])];
      for (int j = 0; j < n; ++j) c[j] = static_cast<uint16_t>((t[j] + area / 2) / area);
    }
  }
  cv::Mat smooth;
  cv::blur(left, smooth, cv::Size(step, step));
  cv::Mat guide(gh, gw, CV_8UC1);
  for (int gy = 0; gy < gh; ++gy) {
    for (int gx = 0; gx < gw; ++gx)
      guide.at<uint8_t>(gy, gx) = smooth.at<uint8_t>(off + gy * step, off + gx * step);
  }
  std::vector<uint16_t> sum;
  aggregateSemiGlobal(v, guide, o.coarse_sgm, sum);
  cv::Mat coarse(gh, gw, CV_32FC1);
  for (int gy = 0; gy < gh; ++gy) {
    for (int gx = 0; gx < gw; ++gx) {
      const std::size_t p = static_cast<std::size_t>(gy) * gw + gx;
      const int best = argminCost(&sum[static_cast<std::size_t>(v.offset[p])], v.count[p]);
      coarse.at<float>(gy, gx) = static_cast<float>(v.lo[p] + best);
    }
  }
  return coarse;
}

// Fills holes along the row (occlusions, from the background side) or from the 8 neighbours' directions
// (mismatches, median). `occluded` marks LR failures that are occlusions.
void fillHoles(cv::Mat& disp, cv::Mat& valid, cv::Mat& filled, const cv::Mat& occluded) {
  const cv::Mat src = disp.clone();
  const cv::Mat src_valid = valid.clone();
  static const int kDirs[8][2] = {{0, 1}, {0, -1}, {1, 0}, {-1, 0}, {1, 1}, {1, -1}, {-1, 1}, {-1, -1}};
  for (int y = 0; y < disp.rows; ++y) {
    for (int x = 0; x < disp.cols; ++x) {
      if (src_valid.at<uint8_t>(y, x)) continue;
      float found[8];
      int nfound = 0;
      const int ndirs = occluded.at<uint8_t>(y, x) ? 2 : 8;
      for (int k = 0; k < ndirs; ++k) {
        for (int r = 1; r <= kMaxFillReachPx; ++r) {
          const int yy = y + kDirs[k][0] * r;
          const int xx = x + kDirs[k][1] * r;
          if (yy < 0 || yy >= disp.rows || xx < 0 || xx >= disp.cols) break;
          if (src_valid.at<uint8_t>(yy, xx)) {
            found[nfound++] = src.at<float>(yy, xx);
            break;
          }
        }
      }
      if (nfound == 0) continue;
      float value;
      if (ndirs == 2) {
        value = *std::min_element(found, found + nfound);  // the background side
      } else {
        for (int i = 1; i < nfound; ++i) {  // insertion sort of at most 8 values
          for (int j = i; j > 0 && found[j - 1] > found[j]; --j) std::swap(found[j - 1], found[j]);
        }
        value = found[nfound / 2];
      }
      disp.at<float>(y, x) = value;
      valid.at<uint8_t>(y, x) = 255;
      filled.at<uint8_t>(y, x) = 255;
    }
  }
}

// The parallax range of every row: the given ones clamped to the options' disparities, else the options'.
std::vector<RowRange> clampedRowRanges(int rows, const DenseOptions& o,
                                       const std::vector<RowRange>* row_ranges) {
  std::vector<RowRange> ranges;
  if (row_ranges != nullptr) {
    if (static_cast<int>(row_ranges->size()) != rows) {
      throw std::invalid_argument("dense matching: one parallax range per row expected");
    }
    ranges = *row_ranges;
    for (RowRange& r : ranges) {
      r.lo = std::clamp(r.lo, o.min_disparity_px, o.max_disparity_px);
      r.hi = std::clamp(r.hi, r.lo, o.max_disparity_px);
    }
  } else {
    ranges.assign(static_cast<std::size_t>(rows), RowRange{o.min_disparity_px, o.max_disparity_px});
  }
  return ranges;
}

// Texture: the grey range inside the census window. Below the threshold the census bits are noise or zero
// and a "match" would only be the aggregation's guess.
// block_half_px > 0: the grey range inside the union of the census windows of a block (the fill pass).
cv::Mat textureMask(const cv::Mat& left, const DenseOptions& o, int block_half_px = 0) {
  const cv::Mat window = cv::Mat::ones(2 * (kCensusHalfHeight + block_half_px) + 1,
                                       2 * (kCensusHalfWidth + block_half_px) + 1, CV_8UC1);
  cv::Mat hi_img, lo_img;
  cv::dilate(left, hi_img, window, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  cv::erode(left, lo_img, window, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  return (hi_img - lo_img) >= o.min_texture_grey;
}

// The right image's sub-pixel disparity at right pixel xr with integer winner dr, from the same aggregated
// volume: the parabola through S(xr + d, d) for d = dr - 1, dr, dr + 1 (the costs of that right pixel at
// those disparities). NaN where a neighbour lies outside the image or its band, or the costs are flat.
float rightSubpixel(const BandVolume& v, const std::vector<uint16_t>& sum, int y, int xr, int dr) {
  double c[3];
  for (int k = -1; k <= 1; ++k) {
    const int x = xr + dr + k, d = dr + k;
    if (x < 0 || x >= v.cols) return std::numeric_limits<float>::quiet_NaN();
    const std::size_t p = static_cast<std::size_t>(y) * v.cols + x;
    if (d < v.lo[p] || d >= v.lo[p] + v.count[p]) return std::numeric_limits<float>::quiet_NaN();
    c[k + 1] = sum[static_cast<std::size_t>(v.offset[p]) + (d - v.lo[p])];
  }
  const double denom = c[0] + c[2] - 2.0 * c[1];
  if (!(denom > 0.0)) return std::numeric_limits<float>::quiet_NaN();
  return static_cast<float>(dr + (c[0] - c[2]) / (2.0 * denom));
}

// Winner per left pixel into res.disparity and res.valid, and the right image's winner from the same
// aggregated volume for the left-right check; `occluded` marks the pixels that check finds occluded. Where
// the check passes, res.lr_diff_px gets the left sub-pixel disparity less the right one (rightSubpixel).
// `interior` marks the pixels inside their band whose aggregated winner lies strictly inside it: at a band's
// end the evidence points beyond the band (the coarse pass's range does not hold the match), and the fill
// pass, which searches the same band, has nothing to find there.
void selectWinners(const BandVolume& v, const std::vector<uint16_t>& sum, const std::vector<uint8_t>& no_band,
                   const cv::Mat& texture, const DenseOptions& o, DenseResult& res, cv::Mat& occluded,
                   cv::Mat& interior) {
  const int rows = v.rows, cols = v.cols;
  res.disparity = cv::Mat(rows, cols, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  res.valid = cv::Mat::zeros(rows, cols, CV_8UC1);
  res.filled = cv::Mat::zeros(rows, cols, CV_8UC1);
  res.lr_diff_px = cv::Mat(rows, cols, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  std::vector<int> left_int(static_cast<std::size_t>(cols));
  std::vector<uint16_t> right_cost(static_cast<std::size_t>(cols));
  std::vector<int> right_disp(static_cast<std::size_t>(cols));
  for (int y = 0; y < rows; ++y) {
    std::fill(right_cost.begin(), right_cost.end(), UINT16_MAX);
    std::fill(right_disp.begin(), right_disp.end(), INT32_MIN / 2);
    float* drow = res.disparity.ptr<float>(y);
    uint8_t* vrow = res.valid.ptr<uint8_t>(y);
    const uint8_t* texture_row = texture.ptr<uint8_t>(y);
    uint8_t* interior_row = interior.ptr<uint8_t>(y);
    for (int x = 0; x < cols; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * cols + x;
      const uint16_t* s = &sum[static_cast<std::size_t>(v.offset[p])];
      const int lo = v.lo[p], n = v.count[p];
      const int best = argminCost(s, n);
      left_int[static_cast<std::size_t>(x)] = lo + best;
      // xr = x - lo - j lies in [0, cols) for j in [x - lo - cols + 1, x - lo].
      const int j_end = std::min(n, x - lo + 1);
      for (int j = std::max(0, x - lo - cols + 1); j < j_end; ++j) {
        const std::size_t xr = static_cast<std::size_t>(x - lo - j);
        const bool lower = s[j] < right_cost[xr];  // as argminCost, without a branch
        right_disp[xr] = lower ? lo + j : right_disp[xr];
        right_cost[xr] = lower ? s[j] : right_cost[xr];
      }
      if (no_band[p]) continue;
      if (best > 0 && best < n - 1) interior_row[x] = 255;
      // The winner's own census cost: above chance level the pixel's window gives no evidence for it, only
      // the aggregation does (sky, parts of the left image the right one does not see).
      const uint16_t own_cost = v.cost[static_cast<std::size_t>(v.offset[p]) + best];
      if (!texture_row[x] || own_cost > o.max_census_cost_bits) continue;
      if (!uniqueMinimum(s, n, best, o.uniqueness_percent)) continue;
      drow[x] = parabolaDisparity(s, lo, n, best);
      vrow[x] = 255;
    }
    for (int x = 0; x < cols; ++x) {
      if (!vrow[x]) continue;
      const int dl = left_int[static_cast<std::size_t>(x)];
      const int xr = x - dl;
      const int dr = (xr >= 0 && xr < cols) ? right_disp[static_cast<std::size_t>(xr)] : INT32_MIN / 2;
      if (std::abs(dr - dl) > o.lr_max_diff_px) {
        vrow[x] = 0;
        drow[x] = std::numeric_limits<float>::quiet_NaN();
        // Hirschmüller: the right pixel belongs to a nearer surface -> this pixel is occluded.
        if (dr > dl) occluded.at<uint8_t>(y, x) = 255;
        continue;
      }
      res.lr_diff_px.at<float>(y, x) = drow[x] - rightSubpixel(v, sum, y, xr, dr);
    }
  }
}

// Speckles: small connected blobs that differ from their surroundings are removed.
void removeSpeckles(const DenseOptions& o, DenseResult& res) {
  const int rows = res.disparity.rows, cols = res.disparity.cols;
  const int speckle = o.speckle_max_area_px >= 0 ? o.speckle_max_area_px : std::max(20, rows * cols / 2000);
  if (speckle <= 0) return;
  cv::Mat d16(rows, cols, CV_16SC1);
  const int16_t invalid = static_cast<int16_t>((o.min_disparity_px - 1) * 16);
  for (int y = 0; y < rows; ++y) {
    const uint8_t* valid = res.valid.ptr<uint8_t>(y);
    const float* d = res.disparity.ptr<float>(y);
    int16_t* out = d16.ptr<int16_t>(y);
    for (int x = 0; x < cols; ++x) {
      // 16 d rounded half away from zero (std::lround, without its library call): exact in double.
      const double d_16 = static_cast<double>(d[x] * 16.0f);
      out[x] = valid[x] ? static_cast<int16_t>(static_cast<long>(d_16 >= 0.0 ? d_16 + 0.5 : d_16 - 0.5)) : invalid;
    }
  }
  cv::filterSpeckles(d16, invalid, speckle, static_cast<int>(o.speckle_max_step_px * 16.0));
  for (int y = 0; y < rows; ++y) {
    uint8_t* valid = res.valid.ptr<uint8_t>(y);
    float* d = res.disparity.ptr<float>(y);
    const int16_t* kept = d16.ptr<int16_t>(y);
    for (int x = 0; x < cols; ++x) {
      if (valid[x] && kept[x] == invalid) {
        valid[x] = 0;
        d[x] = std::numeric_limits<float>::quiet_NaN();
      }
    }
  }
}

}  // namespace

cv::Mat censusTransform(const cv::Mat& image) {
  cv::Mat padded;
  cv::copyMakeBorder(image, padded, kCensusHalfHeight, kCensusHalfHeight, kCensusHalfWidth, kCensusHalfWidth,
                     cv::BORDER_REPLICATE);
  cv::Mat out(image.rows, image.cols, CV_32SC2);
  const int cols = image.cols;
  // Row by row, neighbour by neighbour (dy, then dx, the centre skipped), the first neighbour in the highest
  // bit: the comparisons of 8 neighbours are gathered in a byte per pixel (loops over the row that the
  // compiler vectorises), then shifted into the pixel's 64 bits.
  std::vector<uint8_t> chunk(static_cast<std::size_t>(cols));
  for (int y = 0; y < image.rows; ++y) {
    uint64_t* o = out.ptr<uint64_t>(y);
    std::fill(o, o + cols, uint64_t{0});
    const uint8_t* centre = padded.ptr<uint8_t>(y + kCensusHalfHeight) + kCensusHalfWidth;
    int in_chunk = 0;
    std::fill(chunk.begin(), chunk.end(), uint8_t{0});
    for (int dy = -kCensusHalfHeight; dy <= kCensusHalfHeight; ++dy) {
      for (int dx = -kCensusHalfWidth; dx <= kCensusHalfWidth; ++dx) {
        if (dx == 0 && dy == 0) continue;
        const uint8_t* row = padded.ptr<uint8_t>(y + kCensusHalfHeight + dy) + kCensusHalfWidth + dx;
        uint8_t* c = chunk.data();
        for (int x = 0; x < cols; ++x)
          c[x] = static_cast<uint8_t>((c[x] << 1) | (row[x] < centre[x] ? 1 : 0));
        if (++in_chunk == 8 || (dy == kCensusHalfHeight && dx == kCensusHalfWidth)) {
          for (int x = 0; x < cols; ++x) o[x] = (o[x] << in_chunk) | c[x];
          std::fill(chunk.begin(), chunk.end(), uint8_t{0});
          in_chunk = 0;
        }
      }
    }
  }
  return out;
}

DenseResult matchRectified(const cv::Mat& left, const cv::Mat& right, const DenseOptions& o,
                           const std::vector<RowRange>* row_ranges, const cv::Mat& mask) {
  checkInput(left, right, o);
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != left.size())) {
    throw std::invalid_argument("dense matching: the mask must be 8-bit of the images' size");
  }
  const int rows = left.rows;
  const int cols = left.cols;
  const std::vector<RowRange> ranges = clampedRowRanges(rows, o, row_ranges);

  DenseResult res;
  double t0 = seconds();
  const cv::Mat cl = censusTransform(left);
  const cv::Mat cr = censusTransform(right);
  res.coarse = coarsePass(left, cl, cr, o, ranges);
  double t1 = seconds();
  res.coarse_seconds = t1 - t0;

  std::vector<uint8_t> no_band;
  BandVolume v = fineBand(res.coarse, rows, cols, o, mask, no_band);
  res.fine_cells = v.cells();
  fineCosts(cl, cr, no_band, o.fine_block_px / 2, v);
  std::vector<uint16_t> sum;
  aggregateSemiGlobal(v, left, o.fine_sgm, sum);
  const cv::Mat texture = textureMask(left, o);
  cv::Mat occluded = cv::Mat::zeros(rows, cols, CV_8UC1);
  cv::Mat interior = cv::Mat::zeros(rows, cols, CV_8UC1);
  selectWinners(v, sum, no_band, texture, o, res, occluded, interior);
  // The two largest buffers of a pair in flight: the block fill and the refinement read the band's layout only.
  std::vector<uint16_t>().swap(v.cost);
  std::vector<uint16_t>().swap(sum);
  res.block = cv::Mat::zeros(rows, cols, CV_8UC1);
  res.block_lr_diff_px = cv::Mat(rows, cols, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  const double t_fill = seconds();
  if (o.fill_block_px > 0) {
    // The pixels left without a match whose block has texture (the grey range over the union of its census
    // windows; a pixel's own window may have none, the block's evidence is the block).
    const cv::Mat candidate = textureMask(left, o, o.fill_block_px / 2) & interior & (res.valid == 0);
    BlockFillParams bp;
    bp.block_half_px = o.fill_block_px / 2;
    bp.stride_px = bp.block_half_px % 2 == 0 ? 2 : 1;
    bp.uniqueness_percent = o.uniqueness_percent;
    bp.max_census_cost_bits = o.max_census_cost_bits;
    bp.lr_max_diff_px = o.lr_max_diff_px;
    bp.no_match_cost = kNoMatchCost;
    blockCheck(cl, cr, v, res.valid, res.disparity, 6, bp, res.block_check_px);
    blockFill(cl, cr, v, candidate, bp, res.disparity, res.valid, res.block, res.block_lr_diff_px);
  }
  double t2 = seconds();
  res.fine_seconds = t2 - t1;
  res.fill_seconds = t2 - t_fill;

  removeSpeckles(o, res);
  res.lr_diff_px.setTo(std::numeric_limits<float>::quiet_NaN(), res.valid == 0);
  res.block_lr_diff_px.setTo(std::numeric_limits<float>::quiet_NaN(), res.valid == 0);
  if (!res.block_check_px.empty())
    res.block_check_px.setTo(std::numeric_limits<float>::quiet_NaN(), res.valid == 0);
  res.block.setTo(0, res.valid == 0);
  if (o.refine_subpixel) {
    res.subpixel = refineSubpixel(left, right, res.disparity, res.valid, o.subpixel, &res.sigma_px);
  }
  if (o.fill_holes) fillHoles(res.disparity, res.valid, res.filled, occluded);
  res.post_seconds = seconds() - t2;
  res.matched_fraction =
      static_cast<double>(cv::countNonZero(res.valid)) / (static_cast<double>(rows) * cols);
  return res;
}

}  // namespace areomap::dense
