// 3x3 solves written out in scalars, for the per-point work of intersection and triangulation (millions of
// points on the ground): the same operations in the same order as Eigen's LDLT<Mat3> (solve) and
// FullPivLU<Mat3> (isInvertible, inverse), so the same bits, without the general-size machinery those
// run through for a 3x3 (pivot searches over blocks, a matrix-product kernel for the inverse's
// triangular solves). Written against Eigen 3.4 (ldlt_inplace<Lower>::unblocked, LDLT::_solve_impl,
// FullPivLU::computeInPlace and _solve_impl); tests/firmware_core/base/Solve3Test.cpp compares every
// bit with Eigen's over random and near-singular matrices, so a change of Eigen's order shows there.
#pragma once

#include <cmath>
#include <limits>
#include <utility>

#include "firmware_core/base/EigenTypes.hpp"

namespace areomap {

// a.ldlt().solve(b) (the lower triangle of `a` is read; diagonal pivoting; a zero pivot's component of
// the solution set to zero, as Eigen's pseudo-inverse of D does). Eigen picks the pivot of step k among
// the diagonal entries k..2, which no earlier step has changed: the pivoting is a symmetric permutation p
// of `a` known from its diagonal alone, followed by the unpivoted factorization written out here.
inline Vec3 ldltSolve3(const Mat3& a, const Vec3& b) {
  int p[3] = {0, 1, 2};
  for (int k = 0; k < 2; ++k) {
    int big = k;  // the largest remaining |diagonal|, the first of equals
    for (int i = k + 1; i < 3; ++i) {
      if (std::fabs(a(p[i], p[i])) > std::fabs(a(p[big], p[big]))) big = i;
    }
    std::swap(p[k], p[big]);
  }
  const auto lower = [&a, &p](int i, int j) { return p[i] >= p[j] ? a(p[i], p[j]) : a(p[j], p[i]); };
  const double d0 = a(p[0], p[0]);
  double d1 = a(p[1], p[1]), d2 = a(p[2], p[2]);
  double l10 = lower(1, 0), l20 = lower(2, 0), l21 = lower(2, 1);
  if (std::fabs(d0) > 0.0) {  // else the whole diagonal is zero: Eigen leaves the matrix as it is
    l10 /= d0;
    l20 /= d0;
    const double t0 = d0 * l10;
    d1 -= l10 * t0;
    l21 -= l20 * t0;
    if (std::fabs(d1) > 0.0) l21 /= d1;
    const double u0 = d0 * l20, u1 = d1 * l21;
    d2 -= l20 * u0 + l21 * u1;
  }
  double x0 = b(p[0]), x1 = b(p[1]), x2 = b(p[2]);
  x1 -= l10 * x0;
  x2 -= l20 * x0 + l21 * x1;
  constexpr double kTiny = std::numeric_limits<double>::min();
  x0 = std::fabs(d0) > kTiny ? x0 / d0 : 0.0;
  x1 = std::fabs(d1) > kTiny ? x1 / d1 : 0.0;
  x2 = std::fabs(d2) > kTiny ? x2 / d2 : 0.0;
  x1 -= l21 * x2;
  x0 -= l10 * x1 + l20 * x2;
  Vec3 x;
  x(p[0]) = x0;
  x(p[1]) = x1;
  x(p[2]) = x2;
  return x;
}

// FullPivLU<Mat3>(a): false when it is not invertible (rank below 3 at Eigen's default threshold), else
// `inverse` = its inverse().
inline bool fullPivInverse3(const Mat3& a, Mat3& inverse) {
  double lu[3][3];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) lu[r][c] = a(r, c);
  }
  int row_t[3] = {0, 1, 2}, col_t[3] = {0, 1, 2};
  double max_pivot = 0.0;
  int pivots = 3;
  for (int k = 0; k < 3; ++k) {
    // The largest |entry| of the corner, column by column (the first of equals).
    int br = k, bc = k;
    double big = std::fabs(lu[k][k]);
    for (int c = k; c < 3; ++c) {
      for (int r = k; r < 3; ++r) {
        const double v = std::fabs(lu[r][c]);
        if (v > big) big = v, br = r, bc = c;
      }
    }
    if (big == 0.0) {
      pivots = k;
      break;
    }
    if (big > max_pivot) max_pivot = big;
    row_t[k] = br;
    col_t[k] = bc;
    if (br != k) {
      for (int c = 0; c < 3; ++c) std::swap(lu[k][c], lu[br][c]);
    }
    if (bc != k) {
      for (int r = 0; r < 3; ++r) std::swap(lu[r][k], lu[r][bc]);
    }
    for (int r = k + 1; r < 3; ++r) lu[r][k] /= lu[k][k];
    for (int c = k + 1; c < 3; ++c) {
      for (int r = k + 1; r < 3; ++r) lu[r][c] -= lu[k][c] * lu[r][k];
    }
  }
  const double threshold = max_pivot * (std::numeric_limits<double>::epsilon() * 3.0);
  if (pivots < 3) return false;
  for (int i = 0; i < 3; ++i) {
    if (!(std::fabs(lu[i][i]) > threshold)) return false;
  }
  // P and Q from the transpositions: row i of P b is row p[i] of b; Q puts c's row i at q[i].
  int p[3] = {0, 1, 2}, q[3] = {0, 1, 2};
  for (int k = 2; k >= 0; --k) std::swap(p[k], p[row_t[k]]);
  for (int k = 0; k < 3; ++k) std::swap(q[k], q[col_t[k]]);
  for (int j = 0; j < 3; ++j) {
    // Column j of P I (row i of the identity goes to row p[i]).
    double c[3] = {0.0, 0.0, 0.0};
    c[p[j]] = 1.0;
    // Unit lower, column by column.
    for (int i = 0; i < 3; ++i) {
      const double bi = c[i];
      for (int r = i + 1; r < 3; ++r) c[r] -= bi * lu[r][i];
    }
    // Upper, from the last row, each row scaled by the reciprocal of its pivot.
    for (int i = 2; i >= 0; --i) {
      c[i] *= 1.0 / lu[i][i];
      const double bi = c[i];
      for (int r = 0; r < i; ++r) c[r] -= bi * lu[r][i];
    }
    for (int i = 0; i < 3; ++i) inverse(q[i], j) = c[i];
  }
  return true;
}

}  // namespace areomap
