#include "ground/dem/KrigingSystem.hpp"

#include <algorithm>
#include <cmath>

namespace areomap::dem {

namespace {

// v <- C^-1 v for C = L L^T, U = L^T (rows f apart), for one right-hand side or two at once (their chains
// interleave): L t = v column by column, then L^T v = t row by row. Every entry subtracts its terms in the
// order of the row-by-row substitution (k ascending), so the result does not depend on the layout.
template <int kRhs>
void solveInPlace(const double* u, int f, double* const (&v)[kRhs]) {
  for (int k = 0; k < f; ++k) {
    const double* uk = &u[k * f];
    for (int r = 0; r < kRhs; ++r) {
      double* vr = v[r];
      vr[k] /= uk[k];
      for (int i = k + 1; i < f; ++i) vr[i] -= uk[i] * vr[k];
    }
  }
  for (int i = f - 1; i >= 0; --i) {
    const double* ui = &u[i * f];
    for (int r = 0; r < kRhs; ++r) {
      double* vr = v[r];
      double a = vr[i];
      for (int k = i + 1; k < f; ++k) a -= ui[k] * vr[k];
      vr[i] = a / ui[i];
    }
  }
}

}  // namespace

KrigingSystem::KrigingSystem(const std::vector<DemPoint>& points, const VariogramModel& model, bool use_point_sigma)
    : points_(points),
      model_(model),
      use_point_sigma_(use_point_sigma),
      psill_(std::max(model.partial_sill_m2, 1e-12)),
      jitter_(1e-9 * (std::max(model.partial_sill_m2, 1e-12) + model.nugget_m2)) {}

// C = L L^T of the cached set into u_ (U = L^T), keeping the columns of L before `first_changed` (rows of U
// the same as for the last set) when the size is unchanged. Right-looking: step k finishes column k of L and
// subtracts its part from the entries to its right.
bool KrigingSystem::factorise(int f, int first_changed) {
  ++factorisations_;
  const int p = first_changed;
  for (int i = p; i < f; ++i) {
    const double* ci = cov_.row(i);
    for (int m = 0; m <= i; ++m) u_[m * f + i] = ci[m];
  }
  for (int k = 0; k < f; ++k) {
    double* uk = &u_[k * f];
    if (k >= p) {
      if (!(uk[k] > 0.0)) {
        factor_rows_ = k;
        return false;
      }
      uk[k] = std::sqrt(uk[k]);
    }
    const int i0 = std::max(p, k + 1);
    for (int i = i0; i < f; ++i) uk[i] /= uk[k];
    for (int m = k + 1; m < f; ++m) {
      const double lmk = uk[m];
      double* um = &u_[m * f];
      for (int i = std::max(m, p); i < f; ++i) um[i] -= lmk * uk[i];
    }
  }
  factor_rows_ = f;
  return true;
}

bool KrigingSystem::solve(int f, const int32_t* idx, const double* d2, double* w, double* c) {
  constexpr int n = kMaxNeighbours;
  if (f < 1 || f > n) return false;
  // Canonical order: the neighbours by ascending index, a neighbour's place being the count of those before
  // it (smaller, or equal and earlier: a stable sort) without data-dependent branches (a sort's would mostly
  // mispredict).
  int order[kMaxNeighbours];
  for (int i = 0; i < f; ++i) {
    int rank = 0;
    for (int j = 0; j < f; ++j) rank += (idx[j] < idx[i] || (idx[j] == idx[i] && j < i)) ? 1 : 0;
    order[rank] = i;
    position_[i] = rank;
  }
  int32_t set[kMaxNeighbours];
  for (int i = 0; i < f; ++i) set[i] = idx[order[i]];
  // The first canonical position where the set differs from the cached one (f: the same set).
  const int cached_f = cov_.size();
  int same_up_to = 0;
  if (cached_f == f) {
    while (same_up_to < f && cov_.set()[same_up_to] == set[same_up_to]) ++same_up_to;
  }
  const bool same = same_up_to == f;
  double x[kMaxNeighbours];
  if (same) {
    ++reuses_;
    if (!cached_ok_) return false;
  } else {
    const int keep = cached_f == f ? std::min(same_up_to, factor_rows_) : 0;
    cov_.update(f, set, [this](int32_t a, int32_t b) {
      const DemPoint& pa = points_[static_cast<std::size_t>(a)];
      if (a == b) return psill_ + noise(pa) + jitter_;
      const DemPoint& pb = points_[static_cast<std::size_t>(b)];
      const double dn = pa.north_m - pb.north_m, de = pa.east_m - pb.east_m;
      return psill_ * model_.correlationFast(std::sqrt(dn * dn + de * de));
    });
    cached_ok_ = factorise(f, keep);
    if (!cached_ok_) return false;
  }
  // x = C^-1 c in the canonical order (c in the caller's order); with a new factorisation y = C^-1 1 too.
  for (int i = 0; i < f; ++i) c[i] = psill_ * model_.correlationFast(std::sqrt(d2[i]));
  for (int i = 0; i < f; ++i) x[i] = c[order[i]];
  if (same) {
    solveInPlace<1>(u_, f, {x});
  } else {
    std::fill(y_, y_ + f, 1.0);
    solveInPlace<2>(u_, f, {y_, x});
    s_ = 0.0;
    for (int i = 0; i < f; ++i) s_ += y_[i];
    cached_ok_ = s_ > 0.0 && std::isfinite(s_);
    if (!cached_ok_) return false;
  }
  double sum_x = 0.0;
  for (int i = 0; i < f; ++i) sum_x += x[i];
  const double mu = (sum_x - 1.0) / s_;
  for (int i = 0; i < f; ++i) w[order[i]] = x[i] - mu * y_[i];
  w[f] = mu;
  return std::isfinite(mu);
}

}  // namespace areomap::dem
