#include "ground/dem/BinnedCloud.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <type_traits>
#include <unordered_map>
#include <utility>

#include "ground/cli/Parallel.hpp"
#include "ground/dem/KeyOrder.hpp"
#include "ground/dem/MedianCrossing.hpp"
#include "ground/dense/LineId.hpp"

namespace areomap::dem {

namespace {

constexpr double kMinRepresentationPoints = 6;  // a plane (3 unknowns) and 3 degrees of freedom

// A bin's least-squares plane z = z0 + b u + c v from its moments (binPoints' Acc: sums of u, v, z and their
// products about the cell's centre); rss: the squared residuals about it. False (b = c = 0, rss the spread
// about the mean) when the points do not span a plane: fewer than kMinRepresentationPoints, or on a line.
template <class Acc>
bool binPlane(const Acc& a, double& b, double& c, double& rss) {
  const double suu = a.uu - a.u * a.u / a.n, suv = a.uv - a.u * a.v / a.n, svv = a.vv - a.v * a.v / a.n;
  const double suz = a.uz - a.u * a.z / a.n, svz = a.vz - a.v * a.z / a.n, szz = a.zz - a.z * a.z / a.n;
  const double det = suu * svv - suv * suv;
  b = c = 0.0;
  rss = szz;
  if (a.n < kMinRepresentationPoints || !(det > 1e-12 * (suu * svv) && det > 0.0)) return false;
  b = (svv * suz - suv * svz) / det;
  c = (suu * svz - suv * suz) / det;
  rss = szz - b * suz - c * svz;
  return true;
}

// The part of the points' noise variance that their number does not average down (phi): errors that one
// pair's points share over a wide part of its view (e.g. a sub-pixel bias that changes only as slowly as the
// image's geometry does), which no bin and no kriging neighbourhood averages away. Measured where two pairs
// see the same ground. In one bin, their mean heights, moved along the bin's plane to one position (the two
// pairs' points sample different parts of a sloping bin), differ by d. Bin by bin d is no measure of phi:
// the two pairs' errors at one ground point are themselves correlated over the first centimetres (the same
// texture matched from nearby views), which makes d smaller than independent errors would, by as much as
// phi makes it larger. So the d of the bins that one pair of pairs shares in a block of kBlockCells x
// kBlockCells cells are averaged: D = mean d over the block's N bins. Their short-range parts, both the
// noise and the pairs' common error, average down over the bins; the pair-wide parts do not:
//   Var(D) = sum_k v_k / N^2 + phi * mean_k (s_p^2 + s_q^2)_k,   v_k = sum over the two of s^2 patch factor
// (s^2 the points' mean noise variance of each pair in bin k). phi is the value for which the MEDIAN of
// D^2 / Var(D) over the blocks is chi-square's median (one degree of freedom): blocks where the two pairs
// see different surfaces (a rock's two sides, occlusion edges, mismatches) are the heavy tail of D, and the
// median is not moved by them whatever their size, as the DEM's "within 1 sigma" is not. 0 with fewer than
// kMinOverlapBlocks blocks, or when phi = 0 already leaves the median at or below chi-square's.
constexpr double kMinOverlapPoints = 4;  // points of each of the two pairs in the bin
constexpr int kBlockCells = 5;           // a block is 5 x 5 cells: about one kriging neighbourhood
constexpr int kMinBlockBins = 8;         // bins the two pairs share in a block
constexpr long long kMinOverlapBlocks = 50;
constexpr long long kCellKeyStride = 1000003LL;  // cell key = row * stride + column (binPoints)

// A pair's points in a bin (count n, in its `fraction` slot until normaliseShares): kept when among the
// kMaxPointPairs largest.
void addShare(PointPairs& s, int32_t pair, double n) {
  int k = 0;
  while (k < kMaxPointPairs && s.pair[k] >= 0 && s.fraction[k] >= n) ++k;
  if (k == kMaxPointPairs) return;
  for (int j = kMaxPointPairs - 1; j > k; --j) {
    s.pair[j] = s.pair[j - 1];
    s.fraction[j] = s.fraction[j - 1];
  }
  s.pair[k] = pair;
  s.fraction[k] = static_cast<float>(n);
}

// Counts to fractions of the kept pairs' points.
void normaliseShares(PointPairs& s) {
  float total = 0.f;
  for (int k = 0; k < kMaxPointPairs && s.pair[k] >= 0; ++k) total += s.fraction[k];
  for (int k = 0; k < kMaxPointPairs && s.pair[k] >= 0; ++k) s.fraction[k] /= total;
}

// A bin that two pairs see with at least kMinOverlapPoints points each (the two with the most; p the lower
// slot, so that d has one sign per pair of pairs): d = their mean heights' difference, moved along the
// bin's plane to one position (the two pairs' points sample different parts of a sloping bin); per pair
// the points' mean noise variance (s2 / n) and the patch factor of its n points.
using OverlapBin = BinSums::Overlap;

// Appends to `out` the overlap bins of `by_cell` (bins sorted by cell, then pair slot; whole cells).
template <class Bins>
void overlapBins(const Bins& by_cell, long long pair_slots, double l_px, std::vector<OverlapBin>& out) {
  using Acc = std::remove_cv_t<std::remove_reference_t<decltype(by_cell[0].second)>>;
  for (std::size_t i = 0; i < by_cell.size();) {
    const long long cell = by_cell[i].first / pair_slots;
    const Acc* best[2] = {nullptr, nullptr};
    long long slot[2] = {0, 0};
    Acc all;
    for (; i < by_cell.size() && by_cell[i].first / pair_slots == cell; ++i) {
      const Acc& a = by_cell[i].second;
      all.addCell(a);
      if (a.n < kMinOverlapPoints) continue;
      const long long k = by_cell[i].first % pair_slots;
      if (best[0] == nullptr || a.n > best[0]->n) {
        best[1] = best[0];
        slot[1] = slot[0];
        best[0] = &a;
        slot[0] = k;
      } else if (best[1] == nullptr || a.n > best[1]->n) {
        best[1] = &a;
        slot[1] = k;
      }
    }
    if (best[1] == nullptr || cell < 0 || slot[0] == 0 || slot[1] == 0) continue;  // slot 0: no pair's
    if (slot[0] > slot[1]) {
      std::swap(best[0], best[1]);
      std::swap(slot[0], slot[1]);
    }
    double b = 0.0, c = 0.0, rss = 0.0;
    binPlane(all, b, c, rss);
    const Acc &p = *best[0], &q = *best[1];
    const double d = (p.z / p.n - q.z / q.n) - b * (p.u / p.n - q.u / q.n) - c * (p.v / p.n - q.v / q.n);
    out.push_back({cell, slot[0], slot[1], d, p.s2 / p.n, q.s2 / q.n,
                   patchVarianceFactor(std::sqrt(p.n), l_px), patchVarianceFactor(std::sqrt(q.n), l_px)});
  }
}

double sharedNoiseFraction(const std::vector<OverlapBin>& bins, long long pair_slots,
                           long long& overlap_bins) {
  struct Block {
    double sum_d = 0.0, sum_v = 0.0, sum_base = 0.0;
    int bins = 0;
  };
  std::unordered_map<long long, Block> blocks;  // key: block row, block column, the two pair slots
  overlap_bins = 0;
  for (const OverlapBin& o : bins) {
    const double v = o.mean_var_p * o.factor_p + o.mean_var_q * o.factor_q,
                 base = o.mean_var_p + o.mean_var_q;
    if (!(base > 0.0)) continue;
    ++overlap_bins;
    const long long row = o.cell / kCellKeyStride, col = o.cell % kCellKeyStride;
    const long long key =
        (((row / kBlockCells) * (kCellKeyStride / kBlockCells + 1) + col / kBlockCells) * pair_slots +
         o.slot_p) *
            pair_slots +
        o.slot_q;
    Block& blk = blocks[key];
    blk.sum_d += o.d;
    blk.sum_v += v;
    blk.sum_base += base;
    ++blk.bins;
  }
  struct Overlap {
    double d2, pred, base;
  };
  std::vector<Overlap> overlaps;
  for (const auto& [key, blk] : blocks) {
    if (blk.bins < kMinBlockBins) continue;
    const double n = blk.bins, mean_d = blk.sum_d / n;
    overlaps.push_back({mean_d * mean_d, blk.sum_v / (n * n), blk.sum_base / n});
  }
  if (static_cast<long long>(overlaps.size()) < kMinOverlapBlocks) return 0.0;
  // The median does not depend on the blocks' (the unordered map's) order.
  return medianCrossing(overlaps.size(), 0.0, 1.0, true, [&](std::size_t k, double phi) {
    return overlaps[k].d2 / (overlaps[k].pred + phi * overlaps[k].base);
  });
}

// The correlation rho of two pairs' bin-mean errors where both see a bin (the same ground matched from two
// views: the same relief and texture smooth both pairs' disparities alike). Their difference d has
// Var(d) = V_p + V_q - 2 rho sqrt(V_p V_q), V = Var(pair's mean) of the model (with phi); rho is the value at
// which the median of d^2 / Var(d) over the bins is chi-square's median, in [0, kMaxCommonCorrelation];
// 0 with fewer than kMinOverlapBins bins or when rho = 0 leaves the median at or above chi-square's. What
// two pairs share, the DEM does not average down where they overlap (binPoints adds it to the bin's
// variance); the overlap test of phi cancels it, which is why phi is measured over blocks.
constexpr double kMaxCommonCorrelation = 0.9;
constexpr long long kMinOverlapBins = 200;

double commonErrorCorrelation(const std::vector<OverlapBin>& bins, double phi) {
  struct Overlap {
    double d2, sum, cross;  // d^2, V_p + V_q, 2 sqrt(V_p V_q)
  };
  std::vector<Overlap> overlaps;
  for (const OverlapBin& o : bins) {
    const double vp = o.mean_var_p * (o.factor_p + phi), vq = o.mean_var_q * (o.factor_q + phi);
    if (vp > 0.0 && vq > 0.0) overlaps.push_back({o.d * o.d, vp + vq, 2.0 * std::sqrt(vp * vq)});
  }
  if (static_cast<long long>(overlaps.size()) < kMinOverlapBins) return 0.0;
  return medianCrossing(overlaps.size(), 0.0, kMaxCommonCorrelation, false, [&](std::size_t k, double rho) {
    return overlaps[k].d2 / (overlaps[k].sum - rho * overlaps[k].cross);
  });
}

// A bin's sums: its points' count, position, height and noise, and their moments about the cell's centre
// (u north, v east) for the bin's plane.
struct BinAcc {
  double n = 0, x = 0, y = 0, z = 0, s2 = 0;
  double u = 0, v = 0, uu = 0, uv = 0, vv = 0, uz = 0, vz = 0, zz = 0;
  // The cell's sums over its pairs (s2 apart: the noise is kept per pair).
  void addCell(const BinAcc& o) {
    for (auto m : {&BinAcc::n, &BinAcc::x, &BinAcc::y, &BinAcc::z, &BinAcc::u, &BinAcc::v, &BinAcc::uu,
                   &BinAcc::uv, &BinAcc::vv, &BinAcc::uz, &BinAcc::vz, &BinAcc::zz}) {
      this->*m += o.*m;
    }
  }
};

constexpr long long kBinPairSlots = 4096;  // pairs per cell key (pair ids beyond share a slot: one pair)

// A bin's key (row, column, pair slot: (row * kCellKeyStride + column) * kBinPairSlots + slot) and sums;
// `row` apart, for the bins' order.
struct KeyedBin {
  long long first;
  BinAcc second;
  long long row;
};

// The cloud's runs by pair slot (slots in increasing order, a slot's runs in the cloud's order): a bin
// holds the points of one slot.
using SlotRuns = std::vector<std::pair<long long, std::vector<PackedCloud::Run>>>;

SlotRuns runsBySlot(const PackedCloud& cloud) {
  std::map<long long, std::vector<PackedCloud::Run>> runs_of_slot;
  for (const PackedCloud::Run& run : cloud.runs()) {
    // Every line of a run has the run's pair (line_base is a multiple of kLineRowsPerPair): one slot.
    const long long slot = run.line_base >= 0 ? (dense::linePair(run.line_base) + 1) % kBinPairSlots : 0;
    runs_of_slot[slot].push_back(run);
  }
  return SlotRuns(runs_of_slot.begin(), runs_of_slot.end());
}

// The grid row of a point that keep accepts, false for the others (and rows beyond 1e9).
bool binRow(const DemPoint& p, const DemGrid& grid, const std::function<bool(const DemPoint&)>& keep,
            long long& row) {
  const double r = std::floor((grid.north0_m - p.north_m) / grid.cell_m);
  if (!keep(p) || !(std::fabs(r) < 1e9)) return false;
  row = static_cast<long long>(r);
  return true;
}

// The bins of the points that keep(p) accepts in rows [row_lo, row_hi], in the order of rows, then of
// keys, each the sum over its points in the cloud's order: slot by slot (in parallel), a slot's points
// sorted by (row, column, place in the cloud) and summed bin by bin; then the bins of every slot sorted.
// A point's row from its north coordinate alone (bandSums' first test: most points lie in other bands).
double northRow(const PackedCloud& cloud, const DemGrid& grid, std::size_t i) {
  return std::floor((grid.north0_m - cloud.northOf(i)) / grid.cell_m);
}

// Per block of kRowBlock consecutive points of the cloud: the least and the greatest northRow of its points
// within 1e9 (lo > hi: none), so that a band passes over the blocks that hold none of its rows without
// reading their points (one image row's neighbouring pixels lie on neighbouring ground: a block spans a
// few rows).
constexpr std::size_t kRowBlock = 64;
constexpr std::size_t kBlocksPerTask = 4096;
struct RowSpan {
  int32_t lo = std::numeric_limits<int32_t>::max(), hi = std::numeric_limits<int32_t>::min();
};

std::vector<RowSpan> blockRows(const PackedCloud& cloud, const DemGrid& grid) {
  const std::size_t blocks = (cloud.size() + kRowBlock - 1) / kRowBlock;
  std::vector<RowSpan> spans(blocks);
  cli::parallelFor((blocks + kBlocksPerTask - 1) / kBlocksPerTask, 0, [&](std::size_t t) {
    for (std::size_t b = t * kBlocksPerTask; b < std::min(blocks, (t + 1) * kBlocksPerTask); ++b) {
      for (std::size_t i = b * kRowBlock; i < std::min(cloud.size(), (b + 1) * kRowBlock); ++i) {
        const double row = northRow(cloud, grid, i);
        if (!(std::fabs(row) < 1e9)) continue;
        spans[b].lo = std::min(spans[b].lo, static_cast<int32_t>(row));
        spans[b].hi = std::max(spans[b].hi, static_cast<int32_t>(row));
      }
    }
  });
  return spans;
}

std::vector<KeyedBin> bandSums(const PackedCloud& cloud, const SlotRuns& slots,
                               const std::vector<RowSpan>& spans, const DemGrid& grid,
                               const std::function<bool(const DemPoint&)>& keep, long long row_lo,
                               long long row_hi) {
  std::vector<std::vector<KeyedBin>> bins_of_slot(slots.size());
  cli::parallelFor(slots.size(), 0, [&](std::size_t k) {
    const std::vector<PackedCloud::Run>& runs = slots[k].second;
    struct Keyed {
      long long key;  // column * kBinPairSlots + slot
      std::size_t index;
      int32_t row;
      uint32_t run;
      bool operator<(const Keyed& o) const {
        return row != o.row ? row < o.row : key != o.key ? key < o.key : index < o.index;
      }
    };
    std::vector<Keyed> keyed;
    for (uint32_t ri = 0; ri < runs.size(); ++ri) {
      for (std::size_t i = runs[ri].first; i < runs[ri].end;) {
        const std::size_t block_end = std::min(runs[ri].end, (i / kRowBlock + 1) * kRowBlock);
        const RowSpan& span = spans[i / kRowBlock];
        if (span.lo > row_hi || span.hi < row_lo) {
          i = block_end;
          continue;
        }
        for (; i < block_end; ++i) {
          const double row = northRow(cloud, grid, i);
          if (!(std::fabs(row) < 1e9) || row < static_cast<double>(row_lo) ||
              row > static_cast<double>(row_hi))
            continue;
          const DemPoint p = cloud.at(runs[ri], i);
          long long r = 0;
          if (!binRow(p, grid, keep, r)) continue;
          const long long c = static_cast<long long>(std::floor((p.east_m - grid.east0_m) / grid.cell_m));
          keyed.push_back(Keyed{c * kBinPairSlots + slots[k].first, i, static_cast<int32_t>(r), ri});
        }
      }
    }
    // By cell (row, column: the key's order, its slot the same throughout), then place in the cloud.
    const long long slot = slots[k].first, width = grid.cols + 1;
    const auto cell = [&](const Keyed& q) { return q.row * width + (q.key - slot) / kBinPairSlots; };
    keyOrder(keyed, cell, std::less<Keyed>());
    std::vector<KeyedBin>& out = bins_of_slot[k];
    for (std::size_t j = 0; j < keyed.size(); ++j) {
      const Keyed& q = keyed[j];
      if (j == 0 || q.row != keyed[j - 1].row || q.key != keyed[j - 1].key)
        out.push_back(KeyedBin{q.row * kCellKeyStride * kBinPairSlots + q.key, BinAcc{}, q.row});
      const DemPoint p = cloud.at(runs[q.run], q.index);
      BinAcc& a = out.back().second;
      a.n += 1;
      a.x += p.north_m;
      a.y += p.east_m;
      a.z += p.elevation_m;
      a.s2 += p.sigma_m * p.sigma_m;
      const long long c = static_cast<long long>(std::floor((p.east_m - grid.east0_m) / grid.cell_m));
      const double u = p.north_m - grid.northOfRow(q.row), v = p.east_m - grid.eastOfCol(static_cast<int>(c));
      a.u += u;
      a.v += v;
      a.uu += u * u;
      a.uv += u * v;
      a.vv += v * v;
      a.uz += u * p.elevation_m;
      a.vz += v * p.elevation_m;
      a.zz += p.elevation_m * p.elevation_m;
    }
  });
  std::vector<KeyedBin> all;
  std::size_t total = 0;
  for (const auto& b : bins_of_slot) total += b.size();
  all.reserve(total);
  for (auto& b : bins_of_slot) {
    all.insert(all.end(), b.begin(), b.end());
    std::vector<KeyedBin>().swap(b);
  }
  // By row, then by key (within a row the key's order is the column's, then the slot's; a column outside
  // the grid moves no bin into another row).
  std::sort(all.begin(), all.end(), [](const KeyedBin& a, const KeyedBin& b) {
    return a.row != b.row ? a.row < b.row : a.first < b.first;
  });
  return all;
}

// The bin's relief beyond its plane (BinnedCloud): the residual variance of the heights about their
// least-squares plane, less what the points' noise puts there.
double representationVariance(const BinAcc& a, double noise_spread) {
  if (a.n < kMinRepresentationPoints) return 0.0;
  double b = 0.0, c = 0.0, rss = 0.0;
  binPlane(a, b, c, rss);
  return std::max(0.0, (rss - noise_spread) / (a.n - 3.0));
}

// The cells of `by_cell` (whole cells, sorted) as a band of sums: each cell's mean and relief, its pair
// slots' sums.
BinSums::Band bandCells(const std::vector<KeyedBin>& by_cell, double l_px) {
  BinSums::Band band;
  for (std::size_t i = 0; i < by_cell.size();) {
    const long long cell = by_cell[i].first / kBinPairSlots;
    BinAcc all;
    double noise_spread = 0.0;  // sum_p s_p^2 n_p (1 - patch factor): the noise about the mean
    uint32_t pairs = 0;
    for (; i < by_cell.size() && by_cell[i].first / kBinPairSlots == cell; ++i) {
      const BinAcc& a = by_cell[i].second;
      all.addCell(a);
      noise_spread += a.s2 * (1.0 - patchVarianceFactor(std::sqrt(a.n), l_px));
      band.pair_sums.push_back(BinSums::PairSum{a.n, a.s2, by_cell[i].first % kBinPairSlots});
      ++pairs;
    }
    band.cells.push_back(BinSums::Cell{all.x / all.n, all.y / all.n, all.z / all.n, all.n,
                                       static_cast<float>(representationVariance(all, noise_spread)), pairs});
  }
  return band;
}

// Bands of grid rows summed a band per thread at a time, about a sixteenth of the points each with one
// thread (a 1/(16 T) part with T threads).
constexpr std::size_t kBinBands = 16;

}  // namespace

BinSums sumBins(const PackedCloud& cloud, const DemGrid& grid,
                const std::function<bool(const DemPoint&)>& keep, double correlation_px) {
  BinSums sums;
  const SlotRuns slots = runsBySlot(cloud);
  const std::vector<RowSpan> spans = blockRows(cloud, grid);
  // Points per row, rows beyond the grid by more than its height counted with the outermost ones (the
  // bands' sizes only).
  const long long lo = -static_cast<long long>(grid.rows), hi = 2LL * grid.rows;
  // Counted slot by slot in parallel, then summed.
  std::vector<std::size_t> per_row(static_cast<std::size_t>(hi - lo + 1), 0);
  std::vector<std::vector<std::size_t>> per_slot(slots.size());
  cli::parallelFor(slots.size(), 0, [&](std::size_t k) {
    per_slot[k].assign(per_row.size(), 0);
    for (const PackedCloud::Run& run : slots[k].second) {
      for (std::size_t i = run.first; i < run.end; ++i) {
        long long r = 0;
        if (binRow(cloud.at(run, i), grid, keep, r))
          ++per_slot[k][static_cast<std::size_t>(std::clamp(r, lo, hi) - lo)];
      }
    }
  });
  for (const std::vector<std::size_t>& rows : per_slot) {
    for (std::size_t r = 0; r < rows.size(); ++r) {
      per_row[r] += rows[r];
      sums.binned_points += static_cast<long long>(rows[r]);
    }
  }
  // kBinBands bands for each thread's band in flight: as many bins held as a serial run holds. A bin lies
  // in one row and a band holds whole rows, so the bands' bounds do not change the sums.
  const std::size_t in_flight = static_cast<std::size_t>(cli::threadCount());
  const std::size_t band_points =
      std::max<std::size_t>(1, static_cast<std::size_t>(sums.binned_points) / (kBinBands * in_flight));
  std::vector<std::pair<long long, long long>> bands;  // rows [lo, hi] of the bands that hold points
  for (std::size_t first = 0; first < per_row.size();) {
    std::size_t last = first, n = per_row[first];
    while (last + 1 < per_row.size() && n + per_row[last + 1] <= band_points) n += per_row[++last];
    const long long row_lo =
        first == 0 ? std::numeric_limits<long long>::min() : lo + static_cast<long long>(first);
    const long long row_hi = last + 1 == per_row.size() ? std::numeric_limits<long long>::max()
                                                        : lo + static_cast<long long>(last);
    if (n > 0) bands.emplace_back(row_lo, row_hi);
    first = last + 1;
  }
  // The bands summed as many at a time as there are threads (a band's points lie in a few pairs' slots,
  // which leaves the other threads of its slot-parallel sums idle), appended in the order of their rows:
  // the sums of a serial run.
  struct MadeBand {
    BinSums::Band band;
    std::vector<BinSums::Overlap> overlaps;
  };
  cli::orderedFor(
      bands.size(), 0,
      [&](std::size_t b) {
        MadeBand m;
        const std::vector<KeyedBin> by_cell =
            bandSums(cloud, slots, spans, grid, keep, bands[b].first, bands[b].second);
        overlapBins(by_cell, kBinPairSlots, correlation_px, m.overlaps);
        m.band = bandCells(by_cell, correlation_px);
        return m;
      },
      [&](std::size_t, MadeBand m) {
        sums.overlaps.insert(sums.overlaps.end(), m.overlaps.begin(), m.overlaps.end());
        sums.bands.push_back(std::move(m.band));
      });
  return sums;
}

BinnedCloud finishBins(BinSums sums, double cell_m, double correlation_px) {
  const double l_px = correlation_px;
  long long overlap_bins = 0;
  const double shared = sharedNoiseFraction(sums.overlaps, kBinPairSlots, overlap_bins);
  const double common = commonErrorCorrelation(sums.overlaps, shared);
  std::vector<BinSums::Overlap>().swap(sums.overlaps);
  struct Binned {
    DemPoint point;
    float gsd_m, rep_var_m2, pair_sd_m;
    PointPairs pairs;
  };
  // The bands as many at a time as there are threads, each into its own slice of `out` (the cells in the
  // bands' order, as one thread would append them) and freed once done: `out` grows as the bands shrink.
  std::vector<std::size_t> first_cell(sums.bands.size() + 1, 0);
  for (std::size_t b = 0; b < sums.bands.size(); ++b)
    first_cell[b + 1] = first_cell[b] + sums.bands[b].cells.size();
  std::vector<Binned> out;
  out.reserve(first_cell.back());
  const auto by_position = [](const Binned& a, const Binned& b) {
    return a.point.north_m != b.point.north_m ? a.point.north_m < b.point.north_m
                                              : a.point.east_m < b.point.east_m;
  };
  const std::size_t at_once = static_cast<std::size_t>(cli::threadCount());
  for (std::size_t b0 = 0; b0 < sums.bands.size(); b0 += at_once) {
    const std::size_t b1 = std::min(sums.bands.size(), b0 + at_once);
    out.resize(first_cell[b1]);
    cli::parallelFor(b1 - b0, 0, [&](std::size_t j) {
      BinSums::Band& band = sums.bands[b0 + j];
      std::size_t k = 0;  // the cell's first pair slot in band.pair_sums
      Binned* next = &out[first_cell[b0 + j]];
      for (const BinSums::Cell& cell : band.cells) {
        double var_n2 = 0.0, n_max = 0.0;  // sum_p n_p^2 Var(pair's mean); the most points of one pair
        double shared_n2 = 0.0;            // the pair-wide part of var_n2
        double sum_sd_n = 0.0;             // sum_p n_p sd(pair's mean), for the pairs' common error
        long long pair_max = 0;
        PointPairs shares;  // the largest kMaxPointPairs pairs by points, fractions of those kept
        for (const std::size_t end = k + cell.pair_count; k < end; ++k) {
          const BinSums::PairSum& a = band.pair_sums[k];
          if (a.slot > 0) addShare(shares, static_cast<int32_t>(a.slot - 1), a.n);
          const double factor = patchVarianceFactor(std::sqrt(a.n), l_px);
          var_n2 += a.n * a.n * (a.s2 / a.n) * (factor + shared);
          shared_n2 += a.n * a.n * (a.s2 / a.n) * shared;
          sum_sd_n += a.n * std::sqrt((a.s2 / a.n) * (factor + shared));
          if (a.n > n_max) {
            n_max = a.n;
            pair_max = a.slot;
          }
        }
        // Two pairs' errors in one bin are correlated by `common`: Var(mean) gains
        // sum_{p != q} n_p n_q rho sd_p sd_q / n^2 = rho ((sum_p n_p sd_p)^2 - sum_p n_p^2 sd_p^2) / n^2.
        var_n2 += common * std::max(0.0, sum_sd_n * sum_sd_n - var_n2);
        DemPoint p;
        p.north_m = cell.north_m;
        p.east_m = cell.east_m;
        p.elevation_m = cell.elevation_m;
        p.sigma_m = std::sqrt(var_n2) / cell.n;
        p.line =
            pair_max > 0 ? dense::lineId(pair_max - 1, 0) : -1;  // the pair of most of its points (row 0)
        normaliseShares(shares);
        *next++ = Binned{p, static_cast<float>(cell_m / std::sqrt(n_max)), cell.rep_var_m2,
                         static_cast<float>(std::sqrt(shared_n2) / cell.n), shares};
      }
      std::sort(&out[first_cell[b0 + j]], next, by_position);
      std::vector<BinSums::PairSum>().swap(band.pair_sums);
      std::vector<BinSums::Cell>().swap(band.cells);
    });
  }
  // Sorted by position: the bands hold whole rows north to south (a cell's mean in its cell), so their
  // sorted slices reversed are the order one sort gives (distinct positions); checked, else sorted whole.
  std::reverse(out.begin(), out.end());
  for (std::size_t b = 0; b < sums.bands.size(); ++b)
    std::reverse(out.end() - first_cell[b + 1], out.end() - first_cell[b]);
  const auto tie_or_after = [&](const Binned& a, const Binned& b) { return !by_position(a, b); };
  if (std::adjacent_find(out.begin(), out.end(), tie_or_after) != out.end())
    std::sort(out.begin(), out.end(), by_position);
  BinnedCloud binned;
  binned.points.reserve(out.size());
  binned.gsd_m.reserve(out.size());
  binned.rep_var_m2.reserve(out.size());
  binned.pair_sd_m.reserve(out.size());
  binned.pairs.reserve(out.size());
  binned.shared_noise_fraction = shared;
  binned.common_error_correlation = common;
  binned.overlap_bins = overlap_bins;
  binned.binned_points = sums.binned_points;
  for (const Binned& b : out) {
    binned.points.push_back(b.point);
    binned.gsd_m.push_back(b.gsd_m);
    binned.rep_var_m2.push_back(b.rep_var_m2);
    binned.pair_sd_m.push_back(b.pair_sd_m);
    binned.pairs.push_back(b.pairs);
  }
  return binned;
}

BinnedCloud binPoints(const PackedCloud& cloud, const DemGrid& grid,
                      const std::function<bool(const DemPoint&)>& keep, double correlation_px) {
  return finishBins(sumBins(cloud, grid, keep, correlation_px), grid.cell_m, correlation_px);
}

// Kriging of a binned cloud with the matcher's error correlation (the DEM sigma of Kriging.hpp).
KrigingOptions binnedKrigingOptions(const BinnedCloud& binned, const DemGrid& grid, double correlation_px,
                                    const SharedHeightError* shared) {
  KrigingOptions o;
  o.noise_correlation_px = correlation_px;
  o.point_gsd_m = &binned.gsd_m;
  o.bin_cell_m = grid.cell_m;
  o.point_extra_var_m2 = &binned.rep_var_m2;
  o.point_pair_sd_m = &binned.pair_sd_m;
  if (shared != nullptr) {
    o.point_pairs = &binned.pairs;
    o.shared_error = shared;
  }
  return o;
}

}  // namespace areomap::dem
