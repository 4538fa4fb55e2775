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
// the solution set to zero, as Eigen's pseudo-inverse of D does).
inline Vec3 ldltSolve3(const Mat3& a, const Vec3& b) {
  double m[3][3];  // m[row][col], lower triangle in use
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c <= r; ++c) m[r][c] = a(r, c);
  }
  int t[3] = {0, 1, 2};
  for (int k = 0; k < 3; ++k) {
    // The largest remaining diagonal (the first of equals).
    int big = k;
    for (int i = k + 1; i < 3; ++i) {
      if (std::fabs(m[i][i]) > std::fabs(m[big][big])) big = i;
    }
    t[k] = big;
    if (big != k) {
      for (int j = 0; j < k; ++j) std::swap(m[k][j], m[big][j]);
      for (int i = big + 1; i < 3; ++i) std::swap(m[i][k], m[i][big]);
      std::swap(m[k][k], m[big][big]);
      for (int i = k + 1; i < big; ++i) std::swap(m[i][k], m[big][i]);
    }
    double temp[3];
    if (k > 0) {
      for (int j = 0; j < k; ++j) temp[j] = m[j][j] * m[k][j];
      double dot = m[k][0] * temp[0];
      if (k == 2) dot = dot + m[k][1] * temp[1];
      m[k][k] -= dot;
      if (k == 1) m[2][1] -= m[2][0] * temp[0];
    }
    const double akk = m[k][k];
    const bool valid = std::fabs(akk) > 0.0;
    if (k == 0 && !valid) break;  // the whole diagonal is zero (no swap was made): the matrix as given
    if (valid) {
      for (int i = k + 1; i < 3; ++i) m[i][k] /= akk;
    }
  }
  double x[3] = {b(0), b(1), b(2)};
  for (int k = 0; k < 3; ++k) std::swap(x[k], x[t[k]]);
  x[1] -= m[1][0] * x[0];
  x[2] -= m[2][0] * x[0] + m[2][1] * x[1];
  for (int i = 0; i < 3; ++i) {
    if (std::fabs(m[i][i]) > std::numeric_limits<double>::min())
      x[i] /= m[i][i];
    else
      x[i] = 0.0;
  }
  x[1] -= m[2][1] * x[2];
  x[0] -= m[1][0] * x[1] + m[2][0] * x[2];
  for (int k = 2; k >= 0; --k) std::swap(x[k], x[t[k]]);
  return Vec3(x[0], x[1], x[2]);
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
