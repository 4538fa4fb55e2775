#include "firmware_core/adjust/PcgSolver.hpp"

#include "firmware_core/adjust/ReducedCameraSystem.hpp"

namespace areomap {

void PcgSolver::eliminatePoints(const Network& net, AdjustWorkspace& ws, double damping,
                                double diagonal_factor) {
  // Damped point blocks, the pairs' damped 12x12 blocks (kept in ws.pair_normal), their right-hand sides
  // (in r_, before the reduction) and their reduced inverses (the preconditioner).
  pointBlocks(net, ws, damping);
  for (int32_t pi = 0; pi < net.pairCount(); ++pi) {
    const NetPair& pr = net.pair(pi);
    Mat12 n;
    Vec12 b;
    const int32_t n_touched = pairBlock(net, ws, pi, n, b, true);
    n.diagonal() *= diagonal_factor;
    ws.pair_normal[pi] = n;
    reducePairBlock(ws, n_touched, n, nullptr);
    const Eigen::LDLT<Mat12> ldlt(n);
    pair_inverse_[pi] =
        ldlt.info() == Eigen::Success ? Mat12(ldlt.solve(Mat12::Identity())) : Mat12::Identity();
    if (!pair_inverse_[pi].allFinite()) pair_inverse_[pi].setIdentity();
    scatterPair(pr, b, r_);
  }
}

void PcgSolver::solve(const Network& net, AdjustWorkspace& ws, double relative_tolerance, double damping,
                      int32_t& iterations) {
  eliminatePoints(net, ws, damping, 1.0 + damping + 1e-12);  // Marquardt's scaling with a 1e-12 floor
  reduceRightHandSide(net, ws, r_);
  iterate(net, ws, relative_tolerance, ws.step, iterations);
}

void PcgSolver::solveReduced(const Network& net, const AdjustWorkspace& ws, const double* v,
                             double relative_tolerance, double* x, int32_t& iterations) {
  for (int32_t d = 0; d < 6 * net.imageCount(); ++d) r_[d] = v[d];
  iterate(net, ws, relative_tolerance, x, iterations);
}

void PcgSolver::iterate(const Network& net, const AdjustWorkspace& ws, double relative_tolerance, double* x,
                        int32_t& iterations) {
  const int32_t dim = 6 * net.imageCount();
  // Preconditioned conjugate gradients from x = 0, the right-hand side in r_.
  double rhs_norm2 = 0.0;
  for (int32_t d = 0; d < dim; ++d) {
    x[d] = 0.0;
    rhs_norm2 += r_[d] * r_[d];
  }
  double rz = 0.0;
  for (int32_t stage = 0; stage < kMaxPcgIterations; ++stage) {
    // z = P^-1 r (per pair).
    for (int32_t pi = 0; pi < net.pairCount(); ++pi) {
      const NetPair& pr = net.pair(pi);
      const Vec12 zz = pair_inverse_[pi] * gatherPair(pr, r_);
      scatterPair(pr, zz, z_);
    }
    double rz_new = 0.0;
    for (int32_t d = 0; d < dim; ++d) rz_new += r_[d] * z_[d];
    const double beta = stage == 0 ? 0.0 : rz_new / rz;
    rz = rz_new;
    for (int32_t d = 0; d < dim; ++d) p_[d] = z_[d] + beta * p_[d];
    reducedProduct(net, ws, p_, q_);
    double pq = 0.0;
    for (int32_t d = 0; d < dim; ++d) pq += p_[d] * q_[d];
    if (!(pq > 0.0)) break;
    const double alpha = rz / pq;
    double r2 = 0.0;
    for (int32_t d = 0; d < dim; ++d) {
      x[d] += alpha * p_[d];
      r_[d] -= alpha * q_[d];
      r2 += r_[d] * r_[d];
    }
    ++iterations;
    if (r2 <= relative_tolerance * relative_tolerance * rhs_norm2) break;
  }
}

}  // namespace areomap
