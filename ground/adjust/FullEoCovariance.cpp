#include "ground/adjust/FullEoCovariance.hpp"

#include <memory>
#include <utility>

#include "firmware_core/adjust/Constraints.hpp"
#include "firmware_core/adjust/EoCovariance.hpp"
#include "firmware_core/adjust/FastAdjuster.hpp"

namespace areomap::ground {

namespace {

// Collects S^-1 column block by column block.
class InverseColumns final : public CovarianceColumnSink {
 public:
  explicit InverseColumns(int32_t pairs) : inverse(12 * pairs, 12 * pairs) { inverse.setZero(); }
  void pairColumns(int32_t pair, const Mat12* columns, int32_t pair_count) override {
    for (int32_t j = 0; j < pair_count; ++j) inverse.block<12, 12>(12 * j, 12 * pair) = columns[j];
  }
  Eigen::MatrixXd inverse;
};

}  // namespace

FullEoCovariance fullEoCovariance(Network& net) {
  FullEoCovariance out;
  const int32_t n = net.pairCount();
  InverseColumns columns(n);
  // ~15 MiB of fixed workspace: on the heap here, for one call.
  const auto adjuster = std::make_unique<FastAdjuster>();
  adjuster->setCovarianceSink(&columns);
  FastAdjustResult result;
  out.status = adjuster->precisionOf(net, result);
  if (ok(out.status)) out.status = result.covariance_status;
  out.sigma0 = result.sigma0;
  if (!ok(out.status)) return out;
  // The single images' right halves are no unknowns.
  Eigen::MatrixXd& inv = columns.inverse;
  for (int32_t p = 0; p < n; ++p) {
    if (net.pair(p).right >= 0) continue;
    inv.middleRows(12 * p + 6, 6).setZero();
    inv.middleCols(12 * p + 6, 6).setZero();
  }
  // P = block-diagonal J_j^T J_j of the rows that are no measurement: C = sigma0^2 (S^-1 - S^-1 P S^-1).
  Eigen::MatrixXd jx = Eigen::MatrixXd::Zero(kMaxPairConstraintRows * n, 12 * n);
  out.fixed = Eigen::MatrixXd::Zero(12 * n, 12 * n);
  for (int32_t j = 0; j < n; ++j) {
    ConstraintJacobian rows;
    const int32_t count = nonMeasurementRows(net, j, rows);
    if (count == 0) continue;
    jx.middleRows(kMaxPairConstraintRows * j, count).noalias() =
        rows.topRows(count) * inv.middleRows(12 * j, 12);
    out.fixed.block<12, 12>(12 * j, 12 * j).noalias() = rows.topRows(count).transpose() * rows.topRows(count);
  }
  out.covariance = inv;
  out.covariance.noalias() -= jx.transpose() * jx;
  out.covariance = 0.5 * (out.covariance + out.covariance.transpose()).eval();
  out.covariance *= out.sigma0 * out.sigma0;
  out.inverse = std::move(inv);
  return out;
}

}  // namespace areomap::ground
