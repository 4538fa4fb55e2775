#include "firmware_core/adjust/EoCovariance.hpp"

#include <cmath>

#include "firmware_core/adjust/Constraints.hpp"
#include "firmware_core/adjust/ReducedCameraSystem.hpp"

namespace areomap {

void setPairCovariance(Network& net, int32_t pair, const Mat12& covariance) {
  NetPair& pr = net.pair(pair);
  pr.covariance = covariance;
  if (pr.right < 0) {
    pr.covariance.rightCols<6>().setZero();
    pr.covariance.bottomRows<6>().setZero();
  }
  net.image(pr.left).sigma = pr.covariance.diagonal().head<6>().cwiseMax(0.0).cwiseSqrt();
  if (pr.right >= 0) net.image(pr.right).sigma = pr.covariance.diagonal().tail<6>().cwiseMax(0.0).cwiseSqrt();
}

int32_t networkRedundancy(const Network& net, int32_t active_observations) {
  int32_t constraint_rows = 0;
  for (int32_t p = 0; p < net.pairCount(); ++p) {
    ConstraintRows rows;
    ConstraintJacobian jac;
    constraint_rows += currentPairConstraintRows(net, p, rows, jac);
    if (net.rig.use_datum_prior) constraint_rows -= 3 * (net.pair(p).right >= 0 ? 2 : 1);
  }
  int32_t points = 0;
  for (int32_t p = 0; p < net.pointCount(); ++p) points += net.point(p).solvable ? 1 : 0;
  // The prior fixes the datum's 3 rotations; it is not counted as observations.
  return 2 * active_observations + constraint_rows - 6 * net.imageCount() - 3 * points +
         (net.rig.use_datum_prior ? 3 : 0);
}

void EoCovariance::pcgColumns(const Network& net, const AdjustWorkspace& ws, PcgSolver& pcg, int32_t pair) {
  const NetPair& pr = net.pair(pair);
  const int32_t dim = 6 * net.imageCount();
  const int32_t columns = pr.right >= 0 ? 12 : 6;
  for (int32_t j = 0; j < net.pairCount(); ++j) columns_[j].setZero();
  for (int32_t c = 0; c < columns; ++c) {
    for (int32_t d = 0; d < dim; ++d) v_[d] = 0.0;
    v_[6 * (c < 6 ? pr.left : pr.right) + c % 6] = 1.0;
    int32_t iterations = 0;
    pcg.solveReduced(net, ws, v_, kCovariancePcgTolerance, x_, iterations);
    for (int32_t j = 0; j < net.pairCount(); ++j) columns_[j].col(c) = gatherPair(net.pair(j), x_);
  }
}

void EoCovariance::store(Network& net, int32_t pair, double sigma0) const {
  // C_pp = X_p[p] - sum_j (J_j X_p[j])^T (J_j X_p[j]), J_j pair j's rows that are no measurement.
  Mat12 c = columns_[pair];
  for (int32_t j = 0; j < net.pairCount(); ++j) {
    if (fixed_count_[j] == 0) continue;
    ConstraintJacobian jx;
    jx.noalias() = fixed_rows_[j] * columns_[j];
    c.noalias() -= jx.topRows(fixed_count_[j]).transpose() * jx.topRows(fixed_count_[j]);
  }
  c = 0.5 * (c + c.transpose()).eval();
  c *= sigma0 * sigma0;
  setPairCovariance(net, pair, c);
}

Status EoCovariance::compute(Network& net, AdjustWorkspace& ws, BlockCholesky& cholesky, PcgSolver& pcg,
                             double sigma0, CovarianceSolver& solver, CovarianceSolver use,
                             CovarianceColumnSink* sink) {
  solver = CovarianceSolver::kNone;
  linearize(net, ws);
  if (use != CovarianceSolver::kPcg && cholesky.order(net)) {
    // Undamped: S itself at the solution.
    if (!cholesky.assembleAndFactorUndamped(net, ws)) return Status::kDegenerate;
    solver = CovarianceSolver::kCholesky;
  } else {
    pcg.prepareUndamped(net, ws);
    solver = CovarianceSolver::kPcg;
  }
  for (int32_t p = 0; p < net.pairCount(); ++p) fixed_count_[p] = nonMeasurementRows(net, p, fixed_rows_[p]);
  for (int32_t p = 0; p < net.pairCount(); ++p) {
    if (solver == CovarianceSolver::kCholesky) {
      cholesky.solvePairColumns(net, ws, p, columns_);
    } else {
      pcgColumns(net, ws, pcg, p);
    }
    if (sink != nullptr) sink->pairColumns(p, columns_, net.pairCount());
    store(net, p, sigma0);
    if (!net.pair(p).covariance.allFinite()) return Status::kNotFinite;
  }
  return Status::kOk;
}

}  // namespace areomap
