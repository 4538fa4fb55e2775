#include "firmware_core/adjust/BlockCholesky.hpp"

#include "firmware_core/adjust/ReducedCameraSystem.hpp"

namespace areomap {

bool BlockCholesky::order(const Network& net) {
  const int32_t n = net.pairCount();
  for (int32_t i = 0; i < n; ++i) {
    for (int32_t j = 0; j < n; ++j) graph_[i][j] = false;
  }
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    const NetPoint& pt = net.point(p);
    if (!pt.solvable) continue;
    int32_t pairs[kMaxObsPerPoint];
    int32_t count = 0;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const NetObservation& o = net.observation(pt.obs[k]);
      if (!o.rejected) pairs[count++] = net.image(o.image).pair;
    }
    for (int32_t a = 0; a < count; ++a) {
      for (int32_t b = 0; b < count; ++b) graph_[pairs[a]][pairs[b]] = pairs[a] != pairs[b];
    }
  }
  bool eliminated[kMaxPairs] = {};
  int32_t neighbours[kMaxPairs];
  int32_t blocks = n;  // the diagonal
  for (int32_t step = 0; step < n; ++step) {
    int32_t best = -1;
    int32_t best_degree = kMaxPairs + 1;
    for (int32_t v = 0; v < n; ++v) {
      if (eliminated[v]) continue;
      int32_t degree = 0;
      for (int32_t u = 0; u < n; ++u) degree += (!eliminated[u] && graph_[v][u]) ? 1 : 0;
      if (degree < best_degree) {
        best_degree = degree;
        best = v;
      }
    }
    order_[step] = best;
    position_[best] = step;
    eliminated[best] = true;
    int32_t count = 0;
    for (int32_t u = 0; u < n; ++u) {
      if (!eliminated[u] && graph_[best][u]) neighbours[count++] = u;
    }
    col_start_[step] = blocks - n;
    if (blocks + count > kMaxFactorBlocks) return false;
    for (int32_t a = 0; a < count; ++a) {
      col_rows_[blocks - n + a] = static_cast<int16_t>(neighbours[a]);  // a pair index until all are placed
      for (int32_t b = 0; b < count; ++b) graph_[neighbours[a]][neighbours[b]] = a != b;
    }
    blocks += count;
  }
  col_start_[n] = blocks - n;
  for (int32_t i = 0; i < n; ++i) {
    for (int32_t j = 0; j < n; ++j) block_pos_[i][j] = -1;
  }
  int32_t slot = 0;
  for (int32_t k = 0; k < n; ++k) block_pos_[k][k] = static_cast<int16_t>(slot++);
  for (int32_t k = 0; k < n; ++k) {
    for (int32_t r = col_start_[k]; r < col_start_[k + 1]; ++r) {
      col_rows_[r] = static_cast<int16_t>(position_[col_rows_[r]]);
      block_pos_[col_rows_[r]][k] = static_cast<int16_t>(slot++);
    }
  }
  factor_blocks_ = slot;
  return true;
}

bool BlockCholesky::assembleAndFactor(const Network& net, AdjustWorkspace& ws, double damping) {
  // Marquardt's scaling, with a 1e-12 floor that keeps a step's system positive definite.
  assemble(net, ws, damping, 1.0 + damping + 1e-12);
  return factor(net.pairCount(), ws);
}

bool BlockCholesky::assembleAndFactorUndamped(const Network& net, AdjustWorkspace& ws) {
  assemble(net, ws, 0.0, 1.0);
  return factor(net.pairCount(), ws);
}

void BlockCholesky::assemble(const Network& net, AdjustWorkspace& ws, double damping,
                             double diagonal_factor) {
  // S = C - W N^-1 W^T: the pairs' damped blocks on the diagonal, then each eliminated point's contribution
  // to the blocks of the pairs it couples (lower triangle in elimination order).
  const int32_t n = net.pairCount();
  pointBlocks(net, ws, damping);
  for (int32_t d = 0; d < 144 * factor_blocks_; ++d) ws.pool[d] = 0.0;
  for (int32_t pi = 0; pi < n; ++pi) {
    Mat12 c;
    Vec12 g;
    (void)pairBlock(net, ws, pi, c, g, false);
    c.diagonal() *= diagonal_factor;
    const int32_t q = position_[pi];
    block(ws, q, q) = c;
    Eigen::Map<Vec12>(rhs_ + 12 * q) = g;
  }
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    if (!ws.point_eliminated[p]) continue;
    const NetPoint& pt = net.point(p);
    Mat6x3 w[kMaxObsPerPoint];
    Mat6x3 t[kMaxObsPerPoint];
    int32_t row[kMaxObsPerPoint];
    int32_t offset[kMaxObsPerPoint];
    int32_t count = 0;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const int32_t oi = pt.obs[k];
      if (!ws.obs_valid[oi]) continue;
      const NetImage& im = net.image(net.observation(oi).image);
      w[count].noalias() = ws.obs_d_image[oi].transpose() * ws.obs_d_point[oi];
      t[count].noalias() = w[count] * ws.point_inverse[p];
      row[count] = position_[im.pair];
      offset[count] = im.side == Side::kLeft ? 0 : 6;
      Eigen::Map<Vec12>(rhs_ + 12 * row[count]).segment<6>(offset[count]).noalias() -=
          t[count] * ws.point_rhs[p];
      ++count;
    }
    for (int32_t a = 0; a < count; ++a) {
      for (int32_t b = 0; b < count; ++b) {
        if (row[a] < row[b]) continue;  // the lower triangle only
        block(ws, row[a], row[b]).block<6, 6>(offset[a], offset[b]).noalias() -=
            t[a].lazyProduct(w[b].transpose());
      }
    }
  }
}

bool BlockCholesky::factor(int32_t n, AdjustWorkspace& ws) {
  // Right-looking block Cholesky of the first n block columns, in place.
  for (int32_t k = 0; k < n; ++k) {
    Eigen::Map<Mat12, Eigen::Aligned16> lkk = block(ws, k, k);
    const Eigen::LLT<Mat12> llt(lkk);
    if (llt.info() != Eigen::Success) return false;
    lkk = llt.matrixL();
    const Vec12 diag = lkk.diagonal();
    if (!diag.allFinite() || !(diag.minCoeff() > 1e-9 * diag.maxCoeff())) return false;
    for (int32_t r = col_start_[k]; r < col_start_[k + 1]; ++r) {
      // L_ik L_kk^T = S_ik.
      Eigen::Map<Mat12, Eigen::Aligned16> lik = block(ws, col_rows_[r], k);
      lkk.triangularView<Eigen::Lower>().transpose().solveInPlace<Eigen::OnTheRight>(lik);
    }
    for (int32_t r = col_start_[k]; r < col_start_[k + 1]; ++r) {
      const int32_t i = col_rows_[r];
      const Eigen::Map<const Mat12, Eigen::Aligned16> lik(ws.pool + 144 * block_pos_[i][k]);
      for (int32_t c = col_start_[k]; c < col_start_[k + 1]; ++c) {
        const int32_t j = col_rows_[c];
        if (j > i) continue;
        const Eigen::Map<const Mat12, Eigen::Aligned16> ljk(ws.pool + 144 * block_pos_[j][k]);
        block(ws, i, j).noalias() -= lik.lazyProduct(ljk.transpose());
      }
    }
  }
  return true;
}

void BlockCholesky::solve(const Network& net, AdjustWorkspace& ws) {
  const int32_t n = net.pairCount();
  for (int32_t k = 0; k < n; ++k) {
    Eigen::Map<Vec12> bk(rhs_ + 12 * k);
    block(ws, k, k).triangularView<Eigen::Lower>().solveInPlace(bk);
    for (int32_t r = col_start_[k]; r < col_start_[k + 1]; ++r) {
      Eigen::Map<Vec12>(rhs_ + 12 * col_rows_[r]).noalias() -= block(ws, col_rows_[r], k) * bk;
    }
  }
  for (int32_t k = n - 1; k >= 0; --k) {
    Eigen::Map<Vec12> bk(rhs_ + 12 * k);
    for (int32_t r = col_start_[k]; r < col_start_[k + 1]; ++r) {
      bk.noalias() -=
          block(ws, col_rows_[r], k).transpose() * Eigen::Map<const Vec12>(rhs_ + 12 * col_rows_[r]);
    }
    block(ws, k, k).triangularView<Eigen::Lower>().transpose().solveInPlace(bk);
  }
  for (int32_t pi = 0; pi < n; ++pi) {
    const NetPair& pr = net.pair(pi);
    scatterPair(pr, Eigen::Map<const Vec12>(rhs_ + 12 * position_[pi]), ws.step);
  }
}

void BlockCholesky::solvePairColumns(const Network& net, const AdjustWorkspace& ws, int32_t pair,
                                     Mat12* x) const {
  // Block forward and back substitution with 12 right-hand sides at once, the unknowns of the pair at
  // elimination position k held in x[order_[k]]. The right-hand side is zero above the pair's position.
  const int32_t n = net.pairCount();
  const auto factor_block = [&](int32_t row, int32_t col) { return ws.poolBlock(block_pos_[row][col]); };
  for (int32_t j = 0; j < n; ++j) x[j].setZero();
  x[pair].setIdentity();
  for (int32_t k = position_[pair]; k < n; ++k) {
    Mat12& xk = x[order_[k]];
    const Mat12 lkk = factor_block(k, k);
    lkk.triangularView<Eigen::Lower>().solveInPlace(xk);
    for (int32_t r = col_start_[k]; r < col_start_[k + 1]; ++r) {
      x[order_[col_rows_[r]]].noalias() -= factor_block(col_rows_[r], k) * xk;
    }
  }
  for (int32_t k = n - 1; k >= 0; --k) {
    Mat12& xk = x[order_[k]];
    for (int32_t r = col_start_[k]; r < col_start_[k + 1]; ++r) {
      xk.noalias() -= factor_block(col_rows_[r], k).transpose() * x[order_[col_rows_[r]]];
    }
    const Mat12 lkk = factor_block(k, k);
    lkk.triangularView<Eigen::Lower>().transpose().solveInPlace(xk);
  }
}

}  // namespace areomap
