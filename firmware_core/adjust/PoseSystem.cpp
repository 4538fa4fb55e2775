#include "firmware_core/adjust/PoseSystem.hpp"

#include <cmath>

namespace areomap {

template <int32_t kSites>
void PoseSystem<kSites>::reset(int32_t n) {
  n_ = n < 0 ? 0 : (n > kSites ? kSites : n);
  for (int32_t i = 0; i < n_; ++i) {
    rhs_[i].setZero();
    for (int32_t j = 0; j <= i; ++j) s_[i][j].setZero();
  }
}

template <int32_t kSites>
void PoseSystem<kSites>::add(int32_t i, int32_t j, const Mat6& block) {
  if (i >= j) {
    s_[i][j] += block;
  } else {
    s_[j][i] += block.transpose();
  }
}

template <int32_t kSites>
bool PoseSystem<kSites>::factor(double damping) {
  for (int32_t i = 0; i < n_; ++i) {
    for (int32_t j = 0; j <= i; ++j) {
      Mat6 a = s_[i][j];
      for (int32_t k = 0; k < j; ++k) a.noalias() -= l_[i][k] * l_[j][k].transpose();
      if (i == j) {
        a.diagonal() += damping * s_[i][i].diagonal();
        const Eigen::LLT<Mat6> llt(a);
        if (llt.info() != Eigen::Success) return false;
        l_[i][i] = llt.matrixL();
        if (!(l_[i][i].diagonal().minCoeff() > 0.0) || !l_[i][i].allFinite()) return false;
      } else {
        // L_ij L_jj^T = A  ->  L_ij^T = L_jj^-1 A^T
        const Mat6 at = a.transpose();
        l_[i][j] = l_[j][j].template triangularView<Eigen::Lower>().solve(at).transpose();
      }
    }
  }
  return true;
}

template <int32_t kSites>
void PoseSystem<kSites>::solve(Vec6* x) const {
  for (int32_t i = 0; i < n_; ++i) {
    Vec6 y = rhs_[i];
    for (int32_t k = 0; k < i; ++k) y.noalias() -= l_[i][k] * x[k];
    x[i] = l_[i][i].template triangularView<Eigen::Lower>().solve(y);
  }
  for (int32_t i = n_ - 1; i >= 0; --i) {
    Vec6 y = x[i];
    for (int32_t k = i + 1; k < n_; ++k) y.noalias() -= l_[k][i].transpose() * x[k];
    x[i] = l_[i][i].transpose().template triangularView<Eigen::Upper>().solve(y);
  }
}

template <int32_t kSites>
Mat6 PoseSystem<kSites>::inverseDiagonalBlock(int32_t k) {
  // Columns of block k: forward substitution starts at row block k (the rows above are zero).
  for (int32_t i = 0; i < n_; ++i) work_[i].setZero();
  work_[k] = l_[k][k].template triangularView<Eigen::Lower>().solve(Mat6::Identity());
  for (int32_t i = k + 1; i < n_; ++i) {
    Mat6 y = Mat6::Zero();
    for (int32_t m = k; m < i; ++m) y.noalias() -= l_[i][m] * work_[m];
    work_[i] = l_[i][i].template triangularView<Eigen::Lower>().solve(y);
  }
  for (int32_t i = n_ - 1; i >= k; --i) {
    Mat6 y = work_[i];
    for (int32_t m = i + 1; m < n_; ++m) y.noalias() -= l_[m][i].transpose() * work_[m];
    work_[i] = l_[i][i].transpose().template triangularView<Eigen::Upper>().solve(y);
  }
  return work_[k];
}

template class PoseSystem<kMaxSites>;
template class PoseSystem<kMaxGroundSites>;

}  // namespace areomap
