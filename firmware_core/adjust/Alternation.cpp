#include "firmware_core/adjust/Alternation.hpp"

#include <algorithm>
#include <cmath>

#include "firmware_core/adjust/Constraints.hpp"
#include "firmware_core/adjust/ReducedCameraSystem.hpp"

namespace areomap {

namespace {

using MatHist = Eigen::Matrix<double, kMaxAndersonDepth, kMaxAndersonDepth>;
using VecHist = Eigen::Matrix<double, kMaxAndersonDepth, 1>;

// Every solvable point's 3x3 solve with the EO fixed, relinearised at the current state.
void pointStep(Network& net) {
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    NetPoint& pt = net.point(p);
    if (!pt.solvable) continue;
    Mat3 n = Mat3::Zero();
    Vec3 b = Vec3::Zero();
    int32_t rays = 0;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const NetObservation& o = net.observation(pt.obs[k]);
      if (o.rejected) continue;
      const NetImage& im = net.image(o.image);
      Vec2 r;
      Mat2x3 j;
      if (!ok(observationRow(o, im, im.centre_m, im.m, pt.xyz_m, r, nullptr, &j))) continue;
      n.noalias() += j.transpose() * j;
      b.noalias() += j.transpose() * r;
      ++rays;
    }
    if (rays < 2) continue;  // behind a camera this sweep; tried again next sweep
    const Eigen::LDLT<Mat3> ldlt(n);
    const Vec3 d = ldlt.vectorD();
    if (ldlt.info() != Eigen::Success || !(d.minCoeff() > 1e-14 * d.maxCoeff())) {
      pt.solvable = false;
      continue;
    }
    movePoint(net, pt, ldlt.solve(b));
  }
}

// The EO as a tangent vector against the a-priori EO: [C - C_apriori, log(M M_apriori^T)] per image.
void readTangent(const Network& net, double* x) {
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    const NetImage& im = net.image(i);
    Mat3 d;
    d.noalias() = im.m * im.m_apriori.transpose();
    const Vec3 c = im.centre_m - im.centre_apriori_m;
    const Vec3 w = rotationVector(d);
    for (int32_t k = 0; k < 3; ++k) {
      x[6 * i + k] = c(k);
      x[6 * i + 3 + k] = w(k);
    }
  }
}

void writeTangent(Network& net, const double* x) {
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    NetImage& im = net.image(i);
    const Vec3 c(x[6 * i], x[6 * i + 1], x[6 * i + 2]);
    const Vec3 w(x[6 * i + 3], x[6 * i + 4], x[6 * i + 5]);
    im.centre_m = im.centre_apriori_m + c;
    im.m.noalias() = rotationFromVector(w) * im.m_apriori;
  }
}

// Largest EO difference between two tangent vectors, pixel equivalent.
double largestStepPx(const Network& net, const double* x, const double* g, double nominal_range_m) {
  double step_px = 0.0;
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    const Vec3 dc(g[6 * i] - x[6 * i], g[6 * i + 1] - x[6 * i + 1], g[6 * i + 2] - x[6 * i + 2]);
    const Vec3 dw(g[6 * i + 3] - x[6 * i + 3], g[6 * i + 4] - x[6 * i + 4], g[6 * i + 5] - x[6 * i + 5]);
    step_px = std::max(step_px, eoPixelEquivalent(net.image(i).io.f_px, dc, dw.norm(), nominal_range_m));
  }
  return step_px;
}

}  // namespace

void AndersonAccelerator::reset(const Network& net, double nominal_range_m, int32_t depth) {
  depth_ = std::min(std::max(depth, 1), kMaxAndersonDepth);
  count_ = 0;
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    const double f = net.image(i).io.f_px;
    for (int32_t k = 0; k < 3; ++k) {
      scale_[6 * i + k] = f / nominal_range_m;
      scale_[6 * i + 3 + k] = f;
    }
  }
}

void AndersonAccelerator::push(int32_t dim, const double* x, const double* g) {
  // History of (F = G(x) - x, G(x)), oldest first.
  if (count_ == depth_ + 1) {
    for (int32_t h = 0; h < depth_; ++h) {
      for (int32_t d = 0; d < dim; ++d) {
        hist_f_[h][d] = hist_f_[h + 1][d];
        hist_g_[h][d] = hist_g_[h + 1][d];
      }
    }
    --count_;
  }
  for (int32_t d = 0; d < dim; ++d) {
    hist_f_[count_][d] = g[d] - x[d];
    hist_g_[count_][d] = g[d];
  }
  ++count_;
}

bool AndersonAccelerator::candidate(int32_t dim, const double* g, double* candidate) const {
  const int32_t m = count_ - 1;  // number of differences
  if (m < 1) return false;
  const int32_t newest = count_ - 1;
  MatHist a = MatHist::Identity();
  VecHist rhs = VecHist::Zero();
  // Differences dF_j = F_{j+1} - F_j, j = 0..m-1, in the scaled (pixel-equivalent) inner product.
  for (int32_t i = 0; i < m; ++i) {
    for (int32_t j = i; j < m; ++j) {
      double s = 0.0;
      for (int32_t d = 0; d < dim; ++d) {
        const double sc = scale_[d] * scale_[d];
        s += sc * (hist_f_[i + 1][d] - hist_f_[i][d]) * (hist_f_[j + 1][d] - hist_f_[j][d]);
      }
      a(i, j) = s;
      a(j, i) = s;
    }
    double r = 0.0;
    for (int32_t d = 0; d < dim; ++d) {
      r += scale_[d] * scale_[d] * (hist_f_[i + 1][d] - hist_f_[i][d]) * hist_f_[newest][d];
    }
    rhs(i) = r;
  }
  double trace = 0.0;
  for (int32_t i = 0; i < m; ++i) trace += a(i, i);
  if (!(trace > 0.0)) return false;
  for (int32_t i = 0; i < m; ++i) a(i, i) += 1e-10 * trace;
  const Eigen::LDLT<MatHist> ldlt(a);
  const VecHist gamma = ldlt.solve(rhs);
  if (ldlt.info() != Eigen::Success || !gamma.allFinite()) return false;
  for (int32_t d = 0; d < dim; ++d) {
    double v = g[d];
    for (int32_t i = 0; i < m; ++i) v -= gamma(i) * (hist_g_[i + 1][d] - hist_g_[i][d]);
    candidate[d] = v;
  }
  return true;
}

Status Alternation::sweep(Network& net, AdjustWorkspace& ws, const FastAdjustOptions& options) {
  return options.reduced_pair_solves ? reducedSweep(net, ws) : pairStep(net, ws);
}

Status Alternation::reducedSweep(Network& net, AdjustWorkspace& ws) {
  linearize(net, ws);
  pointBlocks(net, ws, 0.0);
  // Pair after pair: the reduced 12x12 system, its solve, and the points' right-hand sides updated for the
  // pair's step (so that the next pair sees it: Gauss-Seidel on the reduced camera system).
  for (int32_t pi = 0; pi < net.pairCount(); ++pi) {
    Mat12 n;
    Vec12 b;
    const int32_t n_touched = pairBlock(net, ws, pi, n, b, true);
    reducePairBlock(ws, n_touched, n, &b);
    // A pair whose points are all its own is only held by the constraints and the datum prior after the
    // elimination: a relative damping of 1e-9 keeps the solve defined without moving the solution.
    n.diagonal() *= 1.0 + 1e-9;
    const Eigen::LDLT<Mat12> ldlt(n);
    const Vec12 d = ldlt.vectorD();
    if (ldlt.info() != Eigen::Success || !(d.minCoeff() > 1e-15 * d.maxCoeff())) {
      return Status::kDegenerate;
    }
    const Vec12 delta = ldlt.solve(b);
    if (!delta.allFinite()) return Status::kNotFinite;
    const NetPair& pr = net.pair(pi);
    applyCameraUpdate(delta.head<6>(), net.image(pr.left).centre_m, net.image(pr.left).m);
    if (pr.right >= 0)
      applyCameraUpdate(delta.tail<6>(), net.image(pr.right).centre_m, net.image(pr.right).m);
    for (int32_t t = 0; t < n_touched; ++t) {
      const int32_t p = ws.touched[t];
      ws.point_rhs[p].noalias() -= ws.coupling(p).transpose() * delta;
    }
  }
  // Back-substitution of the points (3x3).
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    if (ws.point_eliminated[p]) movePoint(net, net.point(p), ws.point_inverse[p] * ws.point_rhs[p]);
  }
  return Status::kOk;
}

Status Alternation::solve(Network& net, AdjustWorkspace& ws, const FastAdjustOptions& options,
                          FastAdjustResult& result) {
  const int32_t dim = 6 * net.imageCount();
  const int32_t max_sweeps = boundedSweeps(options);
  const int32_t window = boundedWindow(options);
  anderson_.reset(net, options.nominal_range_m, options.anderson_depth);
  double cost_window[kMaxStopWindow + 1] = {};
  pointStep(net);
  double cost = weightedCost(net);
  if (!std::isfinite(cost)) return Status::kNotFinite;
  readTangent(net, x_);
  result.stop_rule = StopRule::kMaxSweeps;
  result.sweeps = 0;
  for (int32_t s = 0; s < max_sweeps; ++s) {
    for (int32_t w = window; w > 0; --w) cost_window[w] = cost_window[w - 1];
    cost_window[0] = cost;
    const Status status = sweep(net, ws, options);
    if (!ok(status)) return status;
    readTangent(net, g_);
    // Largest EO update of this plain sweep, pixel equivalent.
    const double step_px = largestStepPx(net, x_, g_, options.nominal_range_m);
    anderson_.push(dim, x_, g_);

    bool accelerated = false;
    if (options.anderson && anderson_.candidate(dim, g_, candidate_)) {
      writeTangent(net, candidate_);
      pointStep(net);
      const double c = weightedCost(net);
      if (std::isfinite(c) && c < cost) {
        accelerated = true;
        ++result.anderson_accepted;
        cost = c;
        for (int32_t d = 0; d < dim; ++d) x_[d] = candidate_[d];
      } else {
        ++result.anderson_rejected;
      }
    }
    if (!accelerated) {
      writeTangent(net, g_);
      pointStep(net);
      cost = weightedCost(net);
      for (int32_t d = 0; d < dim; ++d) x_[d] = g_[d];
    }
    if (!std::isfinite(cost)) return Status::kNotFinite;
    result.sweeps = s + 1;
    ++result.sweeps_total;
    result.last_step_px = step_px;
    traceSweep(options, s, cost, step_px);
    if (s + 1 >= window) {
      // |change|: a sweep that raised the cost inside the window is no sign of convergence.
      const double change = std::fabs(cost_window[window - 1] - cost);
      if (change <= options.relative_cost_tolerance * cost && step_px < options.eo_step_tolerance_px) {
        result.stop_rule = StopRule::kCostAndStep;
        break;
      }
    }
  }
  return Status::kOk;
}

}  // namespace areomap
