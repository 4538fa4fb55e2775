#include "ground/dense/SemiGlobal.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

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

// Eight disparities at a time in 16-bit lanes: SSE2 on x86-64 (every such CPU has it), else the same
// operations lane by lane. Every value fits a signed 16-bit lane (kMaxSemiGlobalCost, kMaxSemiGlobalPenalty).
constexpr int kLaneCount = 8;
#if defined(__SSE2__)
using Lanes = __m128i;
inline Lanes loadLanes(const int16_t* p) {
  return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p));
}
inline void storeLanes(int16_t* p, Lanes a) {
  _mm_storeu_si128(reinterpret_cast<__m128i*>(p), a);
}
inline Lanes broadcastLanes(int v) {
  return _mm_set1_epi16(static_cast<int16_t>(v));
}
inline Lanes minLanes(Lanes a, Lanes b) {
  return _mm_min_epi16(a, b);
}
inline Lanes addLanes(Lanes a, Lanes b) {
  return _mm_add_epi16(a, b);
}
inline Lanes subLanes(Lanes a, Lanes b) {
  return _mm_sub_epi16(a, b);
}
inline Lanes andLanes(Lanes a, Lanes mask) {
  return _mm_and_si128(a, mask);
}
inline Lanes selectLanes(Lanes mask, Lanes a, Lanes b) {
  return _mm_or_si128(_mm_and_si128(mask, a), _mm_andnot_si128(mask, b));
}
// Lanes whose index (first + 0..7) lies below n: all ones, else zero.
inline Lanes laneMask(int first, int n) {
  return _mm_cmplt_epi16(_mm_add_epi16(_mm_setr_epi16(0, 1, 2, 3, 4, 5, 6, 7), broadcastLanes(first)),
                         broadcastLanes(n));
}
inline int minOfLanes(Lanes a) {
  a = _mm_min_epi16(a, _mm_srli_si128(a, 8));
  a = _mm_min_epi16(a, _mm_srli_si128(a, 4));
  a = _mm_min_epi16(a, _mm_srli_si128(a, 2));
  return static_cast<int16_t>(_mm_cvtsi128_si32(a) & 0xFFFF);
}
#else
struct Lanes {
  int16_t v[kLaneCount];
};
inline Lanes loadLanes(const int16_t* p) {
  Lanes a;
  std::memcpy(a.v, p, sizeof a.v);
  return a;
}
inline void storeLanes(int16_t* p, Lanes a) {
  std::memcpy(p, a.v, sizeof a.v);
}
template <typename F>
inline Lanes eachLane(F f) {
  Lanes r;
  for (int i = 0; i < kLaneCount; ++i) r.v[i] = static_cast<int16_t>(f(i));
  return r;
}
inline Lanes broadcastLanes(int v) {
  return eachLane([v](int) { return v; });
}
inline Lanes minLanes(Lanes a, Lanes b) {
  return eachLane([&](int i) { return std::min(a.v[i], b.v[i]); });
}
inline Lanes addLanes(Lanes a, Lanes b) {
  return eachLane([&](int i) { return a.v[i] + b.v[i]; });
}
inline Lanes subLanes(Lanes a, Lanes b) {
  return eachLane([&](int i) { return a.v[i] - b.v[i]; });
}
inline Lanes andLanes(Lanes a, Lanes mask) {
  return eachLane([&](int i) { return a.v[i] & mask.v[i]; });
}
inline Lanes selectLanes(Lanes mask, Lanes a, Lanes b) {
  return eachLane([&](int i) { return mask.v[i] ? a.v[i] : b.v[i]; });
}
inline Lanes laneMask(int first, int n) {
  return eachLane([=](int i) { return first + i < n ? -1 : 0; });
}
inline int minOfLanes(Lanes a) {
  return *std::min_element(a.v, a.v + kLaneCount);
}
#endif

// The path cost of a disparity that the predecessor's band lacks: above any jump, so it never wins, and
// adding P1 to it stays within a signed 16-bit lane. Path costs are normalised by the predecessor's
// minimum, so a path cost is at most a matching cost + P2' and a jump at most that + P2' (P2' <= P2 + 1).
constexpr int16_t kUnreachable = 0x3FFF;
static_assert(kMaxSemiGlobalCost + 2 * (kMaxSemiGlobalPenalty + 1) < kUnreachable,
              "a jump reaches kUnreachable");
static_assert(kUnreachable + kMaxSemiGlobalPenalty <= INT16_MAX, "kUnreachable + P1 overflows a lane");
// The sum of 8 paths fits a signed lane.
static_assert(8 * (kMaxSemiGlobalCost + kMaxSemiGlobalPenalty + 1) <= INT16_MAX, "the paths' sum overflows");

int roundUpToLanes(int n) {
  return (n + kLaneCount - 1) / kLaneCount * kLaneCount;
}

struct Direction {
  int dy;
  int dx;
};

// A row's path costs of one direction: every pixel's band in a slot of whole lane groups (slot[x] ..
// slot[x] + roundUpToLanes(count)), the lanes past its count and kLaneCount guard lanes before every slot and
// after the last one holding kUnreachable, so that a neighbour's band shifted by a few disparities reads
// kUnreachable where it has none without a test per disparity.
struct RowSlots {
  std::vector<int> slot;  // cols
  int size = 0;           // lanes in use
};

void layoutRow(const BandVolume& v, int y, RowSlots& r) {
  r.slot.resize(static_cast<std::size_t>(v.cols));
  int at = kLaneCount;
  const std::size_t base = static_cast<std::size_t>(y) * v.cols;
  for (int x = 0; x < v.cols; ++x) {
    r.slot[static_cast<std::size_t>(x)] = at;
    at += roundUpToLanes(v.count[base + static_cast<std::size_t>(x)]) + kLaneCount;
  }
  r.size = at;
}

// One direction's state at the pixel being aggregated: where its predecessor's path costs at this pixel's
// disparities lo - 1 .. lo + n are read (`at`), their minimum and the jump penalty.
struct Step {
  const int16_t* at = nullptr;  // nullptr: no predecessor (the path starts here)
  int pmin = 0, jump = 0;
  int16_t* out = nullptr;  // this pixel's slot in the direction's row buffer
  Lanes running_min;
};

// The directions of a pass whose predecessors were already visited: the forward pass runs in scan order,
// the backward pass in reverse scan order; the first two are the 4-path directions.
constexpr Direction kForwardDirections[4] = {{0, -1}, {-1, 0}, {-1, -1}, {-1, 1}};
constexpr Direction kBackwardDirections[4] = {{0, 1}, {1, 0}, {1, 1}, {1, -1}};

// One pass over the image, carrying the path costs of its nd directions (2 or 4; fixed at compile time with
// the pass, so that the loops over the directions unroll with their offsets known and their state in
// registers). Per pixel, the
// directions are stepped together lane group by lane group, and their sum is added to `sum` once.
// Long because: the per-pixel set-up of every direction (predecessor, its slot or a copy, the penalty) and
// the lane loop belong together; split, the loop's state would be passed around per pixel.
template <bool forward, std::size_t nd>
void runPass(const BandVolume& v, const cv::Mat& guide, const SemiGlobalParams& prm,
             std::vector<uint16_t>& sum_volume) {
  static_assert(nd == 2 || nd == 4, "4 or 8 paths");
  constexpr const Direction* dirs = forward ? kForwardDirections : kBackwardDirections;
  const int rows = v.rows;
  const int cols = v.cols;
  int max_count = 0;
  for (int32_t n : v.count) max_count = std::max(max_count, static_cast<int>(n));
  const int max_lanes = roundUpToLanes(max_count);
  int max_row = 0;
  RowSlots this_slots, prev_slots;
  for (int y = 0; y < rows; ++y) {
    layoutRow(v, y, this_slots);
    max_row = std::max(max_row, this_slots.size);
  }
  // Per direction: this row's and the previous row's path costs (slots) and minima (per pixel), and a copy
  // of a predecessor's path costs whose band lies too far from this pixel's (kUnreachable where it has none).
  const std::size_t row_lanes = static_cast<std::size_t>(max_row),
                    copy_lanes = static_cast<std::size_t>(max_lanes + kLaneCount);
  std::vector<int16_t> buffers(nd * (2 * row_lanes + 2 * static_cast<std::size_t>(cols) + copy_lanes));
  int16_t *cur[nd], *prev[nd], *cur_min[nd], *prev_min[nd], *copy[nd];
#pragma GCC unroll 4
  for (std::size_t k = 0; k < nd; ++k) {
    int16_t* b = buffers.data() + k * (2 * row_lanes + 2 * static_cast<std::size_t>(cols) + copy_lanes);
    cur[k] = b;
    prev[k] = b + row_lanes;
    cur_min[k] = b + 2 * row_lanes;
    prev_min[k] = cur_min[k] + cols;
    copy[k] = prev_min[k] + cols;
  }
  // The volume's last pixels: their costs and sums through a buffer of whole lane groups.
  std::vector<int16_t> cost_tail(static_cast<std::size_t>(max_lanes)), sum_tail(cost_tail.size());
  // P2 per grey difference of the neighbours (no division per pixel and path).
  int p2_of_diff[256];
  for (int di = 0; di < 256; ++di) p2_of_diff[di] = std::max(prm.p1 + 1, prm.p2 * 16 / (16 + di));
  const int16_t* cost_all = reinterpret_cast<const int16_t*>(v.cost.data());
  int16_t* sum_all = reinterpret_cast<int16_t*>(sum_volume.data());
  const int64_t cells = v.cells();
  const Lanes unreachable = broadcastLanes(kUnreachable), p1 = broadcastLanes(prm.p1);
  Step steps[nd];

  for (int iy = 0; iy < rows; ++iy) {
    const int y = forward ? iy : rows - 1 - iy;
    const int py = forward ? y - 1 : y + 1;  // the row visited before this one
    const bool has_prev_row = py >= 0 && py < rows;
    layoutRow(v, y, this_slots);
    const std::size_t row_base = static_cast<std::size_t>(y) * cols;
    const std::size_t prev_base = static_cast<std::size_t>(py) * cols;
    const uint8_t* g = guide.ptr<uint8_t>(y);
    const uint8_t* pg = has_prev_row ? guide.ptr<uint8_t>(py) : nullptr;
    const int* slot_of = this_slots.slot.data();
    const int* prev_slot_of = prev_slots.slot.data();
#pragma GCC unroll 4
    for (std::size_t k = 0; k < nd; ++k)  // the guard after the last slot
      storeLanes(cur[k] + this_slots.size - kLaneCount, unreachable);
    for (int ix = 0; ix < cols; ++ix) {
      const int x = forward ? ix : cols - 1 - ix;
      const std::size_t p = row_base + static_cast<std::size_t>(x);
      const int lo = v.lo[p];
      const int n = v.count[p];
      const int lanes = roundUpToLanes(n);
      const int slot = slot_of[x];
#pragma GCC unroll 4
      for (std::size_t k = 0; k < nd; ++k) {
        Step& st = steps[k];
        st.out = cur[k] + slot;
        storeLanes(st.out - kLaneCount, unreachable);  // the guard before the slot
        st.running_min = unreachable;
        st.at = nullptr;
        const int qx = x + dirs[k].dx;
        const bool same_row = dirs[k].dy == 0;
        if ((!same_row && !has_prev_row) || qx < 0 || qx >= cols) continue;
        const std::size_t q = (same_row ? row_base : prev_base) + static_cast<std::size_t>(qx);
        const int16_t* pslot = same_row ? cur[k] + slot_of[qx] : prev[k] + prev_slot_of[qx];
        st.pmin = same_row ? cur_min[k][qx] : prev_min[k][qx];
        st.jump = st.pmin + p2_of_diff[std::abs(static_cast<int>(g[x]) - (same_row ? g[qx] : pg[qx]))];
        const int plo = v.lo[q], plane = roundUpToLanes(v.count[q]);
        // The lane groups read the predecessor's slot at lo - 1 - plo .. lo - plo + lanes.
        const int first = lo - 1 - plo;
        if (first >= -kLaneCount && lo - plo + lanes <= plane + kLaneCount - 1) {
          st.at = pslot + first;
          continue;
        }
        int16_t* buf = copy[k];
        for (int i = 0; i < lanes + 2; ++i) {
          const int j = first + i;
          buf[i] = (j >= 0 && j < plane) ? pslot[j] : kUnreachable;
        }
        st.at = buf;
      }
      const int64_t off = v.offset[p];
      const bool tail = off + lanes > cells;  // the volume's last pixels: whole lane groups past its end
      const int16_t* c = cost_all + off;
      int16_t* s = sum_all + off;
      if (tail) {
        std::copy(c, c + n, cost_tail.data());
        std::copy(s, s + n, sum_tail.data());
        c = cost_tail.data();
        s = sum_tail.data();
      }
      for (int j = 0; j < lanes; j += kLaneCount) {
        const Lanes inside = laneMask(j, n);
        const Lanes cj = loadLanes(c + j);
        Lanes total = loadLanes(s + j);
#pragma GCC unroll 4
        for (std::size_t k = 0; k < nd; ++k) {
          Step& st = steps[k];
          Lanes val = cj;
          if (st.at != nullptr) {
            const Lanes best =
                minLanes(minLanes(broadcastLanes(st.jump), loadLanes(st.at + j + 1)),
                         addLanes(minLanes(loadLanes(st.at + j), loadLanes(st.at + j + 2)), p1));
            val = subLanes(addLanes(cj, best), broadcastLanes(st.pmin));
          }
          val = selectLanes(inside, val, unreachable);
          storeLanes(st.out + j, val);
          st.running_min = minLanes(st.running_min, val);
          total = addLanes(total, andLanes(val, inside));
        }
        storeLanes(s + j, total);
      }
      if (tail) std::copy(sum_tail.data(), sum_tail.data() + n, sum_all + off);
#pragma GCC unroll 4
      for (std::size_t k = 0; k < nd; ++k)
        cur_min[k][x] = static_cast<int16_t>(minOfLanes(steps[k].running_min));
    }
#pragma GCC unroll 4
    for (std::size_t k = 0; k < nd; ++k) {
      std::swap(prev[k], cur[k]);
      std::swap(prev_min[k], cur_min[k]);
    }
    std::swap(prev_slots, this_slots);
  }
}

}  // namespace

void aggregateSemiGlobal(const BandVolume& volume, const cv::Mat& guide, const SemiGlobalParams& params,
                         std::vector<uint16_t>& sum) {
  if (guide.type() != CV_8UC1 || guide.rows != volume.rows || guide.cols != volume.cols) {
    throw std::invalid_argument("aggregateSemiGlobal: guide must be CV_8U of the volume's size");
  }
  if (params.p1 < 0 || params.p2 < 0 || params.p1 > kMaxSemiGlobalPenalty ||
      params.p2 > kMaxSemiGlobalPenalty) {
    throw std::invalid_argument("aggregateSemiGlobal: penalties must lie in 0..kMaxSemiGlobalPenalty");
  }
  if (!volume.cost.empty() &&
      *std::max_element(volume.cost.begin(), volume.cost.end()) > kMaxSemiGlobalCost) {
    throw std::invalid_argument("aggregateSemiGlobal: a matching cost above kMaxSemiGlobalCost");
  }
  sum.assign(volume.cost.size(), 0);
  if (params.paths >= 8) {
    runPass<true, 4>(volume, guide, params, sum);
    runPass<false, 4>(volume, guide, params, sum);
  } else {
    runPass<true, 2>(volume, guide, params, sum);
    runPass<false, 2>(volume, guide, params, sum);
  }
}

}  // namespace areomap::dense
