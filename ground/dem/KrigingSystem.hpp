// The per-cell solve of ordinary kriging, made fast (benchmarked against R's gstat, BENCHMARKS.md "Kriging"):
//
//   [C 1; 1^T 0] [w; mu] = [c; 1]     C: covariances of the k neighbours (+ their noise on the diagonal),
//                                     c: their covariances with the query point
//
// solved without the indefinite (k+1)x(k+1) matrix: C is symmetric positive definite, so it is factorised
// by Cholesky (C = L L^T) and the Lagrange row eliminated by its Schur complement: with y = C^-1 1 and
// s = 1^T y, x = C^-1 c, the multiplier is mu = (1^T x - 1) / s and the weights w = x - mu y.
//
// The neighbours are put in a canonical order (ascending point index) before C is built, so that one
// neighbour SET always gives the same matrix bit for bit: the factorisation (L, y, s) of the last set is
// kept and reused when the next cell has the same neighbours (cells denser than the points), and a cell's
// result never depends on which cell was solved before it (rows can be split between threads and the
// result stays identical). Fixed storage (kMaxNeighbours): no allocation per cell. One object per thread.
//
// A new set usually differs from the last one by a point or two (the next cell along a row), and every
// number of the factorisation is computed as if from scratch, so the parts that do not change are kept
// bit for bit: the covariance of two points that were both in the last set is copied (no exp), and the
// rows of L before the first changed canonical position are kept (row i of L depends only on rows and
// columns 0..i of C). L is computed column by column (right-looking): each entry still subtracts its terms
// in the same order as the textbook row-by-row loop, so the factor is the same bit for bit, but the entries
// of a column are independent of each other and do not wait on one chain of additions.
#pragma once

#include <cstdint>
#include <vector>

#include "ground/dem/Kriging.hpp"
#include "ground/dem/Variogram.hpp"

namespace areomap::dem {

// A value per pair of points of a neighbour set in canonical order (ascending point index; lower triangle
// with the diagonal, row i at row(i), f apart), kept from one set to the next: a pair whose points were
// both in the last set keeps its value (copied, the same bits), the others are computed. Fixed storage.
class PairTable {
 public:
  // Makes `set` (f ascending indices, 1 <= f <= kMaxNeighbours) the current set; pair(a, b) gives the
  // value of points a and b (a == b on the diagonal) where it is not kept. Nothing to do for the same set.
  template <typename Pair>
  void update(int f, const int32_t* set, Pair pair) {
    bool same = f == f_;
    for (int i = 0; same && i < f; ++i) same = set[i] == set_[i];
    if (same) return;
    const double* before = values_[current_];
    double* now = values_[1 - current_];
    int was_at[kMaxNeighbours];  // position of set[i] in the last set, -1 if new (both ascending: a merge)
    for (int i = 0, j = 0; i < f; ++i) {
      while (j < f_ && set_[j] < set[i]) ++j;
      was_at[i] = j < f_ && set_[j] == set[i] ? j : -1;
    }
    for (int i = 0; i < f; ++i) {
      double* row = &now[i * f];
      const double* kept = was_at[i] >= 0 ? &before[was_at[i] * f_] : nullptr;
      for (int j = 0; j <= i; ++j)
        row[j] = kept != nullptr && was_at[j] >= 0 ? kept[was_at[j]] : pair(set[i], set[j]);
    }
    current_ = 1 - current_;
    f_ = f;
    for (int i = 0; i < f; ++i) set_[i] = set[i];
  }
  void clear() { f_ = 0; }

  int size() const { return f_; }
  const int32_t* set() const { return set_; }
  const double* row(int i) const { return &values_[current_][i * f_]; }

 private:
  int f_ = 0;
  int current_ = 0;
  int32_t set_[kMaxNeighbours];
  double values_[2][kMaxNeighbours * kMaxNeighbours];
};

class KrigingSystem {
 public:
  KrigingSystem(const std::vector<DemPoint>& points, const VariogramModel& model, bool use_point_sigma);

  // A point's noise variance on the diagonal: max(nugget, sigma^2) with point sigmas, else the nugget.
  double noise(const DemPoint& p) const {
    return use_point_sigma_ ? std::max(model_.nugget_m2, p.sigma_m * p.sigma_m) : model_.nugget_m2;
  }
  double partialSill() const { return psill_; }

  // The weights of the f neighbours idx[0..f) (squared distances d2 to the query), in the caller's order:
  // w[0..f), the multiplier w[f] (= mu), and the covariances c[0..f) with the query. False when the system
  // is singular or not finite (the caller leaves the cell empty). 1 <= f <= kMaxNeighbours.
  bool solve(int f, const int32_t* idx, const double* d2, double* w, double* c);

  // The neighbour set of the last solve in canonical order (ascending indices), and where each of its
  // neighbours (in the caller's order) stands in it.
  const int32_t* canonicalSet() const { return cov_.set(); }
  const int* canonicalPositions() const { return position_; }

  long long factorisations() const { return factorisations_; }
  long long reuses() const { return reuses_; }

 private:
  bool factorise(int f, int first_changed);

  const std::vector<DemPoint>& points_;
  VariogramModel model_;
  bool use_point_sigma_;
  double psill_, jitter_;
  // The cached neighbour set with its covariance matrix C; U = L^T, the transposed Cholesky factor (upper
  // triangle, row k at u_[k * f]: column k of L), complete in its first factor_rows_ columns (all of them
  // unless the factorisation failed); y = C^-1 1 and s = 1^T y.
  PairTable cov_;
  bool cached_ok_ = false;
  int factor_rows_ = 0;
  int position_[kMaxNeighbours];
  double u_[kMaxNeighbours * kMaxNeighbours];
  double y_[kMaxNeighbours];
  double s_ = 0.0;
  long long factorisations_ = 0, reuses_ = 0;
};

}  // namespace areomap::dem
