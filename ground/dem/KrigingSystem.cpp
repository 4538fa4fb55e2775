#include "ground/dem/KrigingSystem.hpp"

#include <algorithm>
#include <cmath>

namespace areomap::dem {

namespace {

// v <- C^-1 v for C = L L^T (L row-major lower triangle, rows kMaxNeighbours apart): L u = v, L^T v = u.
void solveInPlace(const double* l, int f, double* v) {
  constexpr int n = kMaxNeighbours;
  for (int i = 0; i < f; ++i) {
    double a = v[i];
    const double* li = &l[i * n];
    for (int k = 0; k < i; ++k) a -= li[k] * v[k];
    v[i] = a / li[i];
  }
  for (int i = f - 1; i >= 0; --i) {
    double a = v[i];
    for (int k = i + 1; k < f; ++k) a -= l[k * n + i] * v[k];
    v[i] = a / l[i * n + i];
  }
}

}  // namespace

KrigingSystem::KrigingSystem(const std::vector<DemPoint>& points, const VariogramModel& model, bool use_point_sigma)
    : points_(points),
      model_(model),
      use_point_sigma_(use_point_sigma),
      psill_(std::max(model.partial_sill_m2, 1e-12)),
      jitter_(1e-9 * (std::max(model.partial_sill_m2, 1e-12) + model.nugget_m2)) {}

// C = L L^T for the cached set (row-major lower triangle); y = C^-1 1, s = 1^T y.
bool KrigingSystem::factorise(int f) {
  ++factorisations_;
  constexpr int n = kMaxNeighbours;
  for (int i = 0; i < f; ++i) {
    const DemPoint& pi = points_[static_cast<std::size_t>(cached_idx_[i])];
    double* li = &l_[i * n];
    for (int j = 0; j <= i; ++j) {
      double a;
      if (j == i) {
        a = psill_ + noise(pi) + jitter_;
      } else {
        const DemPoint& pj = points_[static_cast<std::size_t>(cached_idx_[j])];
        const double dn = pi.north_m - pj.north_m, de = pi.east_m - pj.east_m;
        a = psill_ * model_.correlation(std::sqrt(dn * dn + de * de));
      }
      const double* lj = &l_[j * n];
      for (int k = 0; k < j; ++k) a -= li[k] * lj[k];
      if (j < i) {
        li[j] = a / lj[j];
      } else {
        if (!(a > 0.0)) return false;
        li[i] = std::sqrt(a);
      }
    }
  }
  for (int i = 0; i < f; ++i) y_[i] = 1.0;
  solveInPlace(l_, f, y_);
  s_ = 0.0;
  for (int i = 0; i < f; ++i) s_ += y_[i];
  return s_ > 0.0 && std::isfinite(s_);
}

bool KrigingSystem::solve(int f, const int32_t* idx, const double* d2, double* w, double* c) {
  constexpr int n = kMaxNeighbours;
  if (f < 1 || f > n) return false;
  // Canonical order: the neighbours by ascending index (insertion sort of a permutation; f is small).
  int order[kMaxNeighbours];
  for (int i = 0; i < f; ++i) {
    int j = i;
    while (j > 0 && idx[order[j - 1]] > idx[i]) {
      order[j] = order[j - 1];
      --j;
    }
    order[j] = i;
  }
  bool same = cached_f_ == f;
  for (int i = 0; same && i < f; ++i) same = cached_idx_[i] == idx[order[i]];
  if (same) {
    ++reuses_;
  } else {
    cached_f_ = f;
    for (int i = 0; i < f; ++i) cached_idx_[i] = idx[order[i]];
    cached_ok_ = factorise(f);
  }
  if (!cached_ok_) return false;
  // x = C^-1 c in the canonical order (c in the caller's order).
  double x[kMaxNeighbours];
  for (int i = 0; i < f; ++i) c[i] = psill_ * model_.correlation(std::sqrt(d2[i]));
  for (int i = 0; i < f; ++i) x[i] = c[order[i]];
  solveInPlace(l_, f, x);
  double sum_x = 0.0;
  for (int i = 0; i < f; ++i) sum_x += x[i];
  const double mu = (sum_x - 1.0) / s_;
  for (int i = 0; i < f; ++i) w[order[i]] = x[i] - mu * y_[i];
  w[f] = mu;
  return std::isfinite(mu);
}

}  // namespace areomap::dem
