#include "firmware_core/adjust/FastAdjuster.hpp"

#include <algorithm>
#include <cmath>

namespace areomap {

// The adjuster's workspace and the network it works on are static objects of the rover; together they must
// leave most of the 64 MiB budget to the matcher and the DEM.
static_assert(sizeof(FastAdjuster) + sizeof(Network) < kStaticMemoryBudgetBytes / 2,
              "adjustment workspace + network exceed half of the rover's static memory budget");

namespace {

using MatHist = Eigen::Matrix<double, kMaxAndersonDepth, kMaxAndersonDepth>;
using VecHist = Eigen::Matrix<double, kMaxAndersonDepth, 1>;

bool usable(const Network& net, const NetObservation& o) { return !o.rejected && net.point(o.point).solvable; }

// Whitened cost charged for an observation whose point is behind its camera: far above any real residual,
// so that an extrapolated (Anderson) step that flips a point is never taken for a cost decrease.
constexpr double kBehindCameraCost = 1e8;

constexpr int32_t kMaxPointStepHalvings = 12;  // a point step that would cross behind a camera is halved

// Every active ray of point p sees `xyz` in front of its camera.
bool inFrontOfAll(const Network& net, const NetPoint& pt, const Vec3& xyz) {
  for (int32_t k = 0; k < pt.obs_count; ++k) {
    const NetObservation& o = net.observation(pt.obs[k]);
    if (o.rejected) continue;
    const NetImage& im = net.image(o.image);
    if (!(im.m.row(2).dot(xyz - im.center_m) < 0.0)) return false;
  }
  return true;
}

// Moves a point by `delta`, halving the step while it would put the point behind one of its cameras (a
// far point's depth is nearly free and its Gauss-Newton step can overshoot through infinity).
void movePoint(const Network& net, NetPoint& pt, const Vec3& delta) {
  if (!delta.allFinite()) return;
  Vec3 step = delta;
  for (int32_t h = 0; h < kMaxPointStepHalvings; ++h) {
    const Vec3 moved = pt.xyz_m + step;
    if (inFrontOfAll(net, pt, moved)) {
      pt.xyz_m = moved;
      return;
    }
    step *= 0.5;
  }
}

// Adds a pair's constraint rows (gimbal, base and the FIDO variants) to its 12x12 normal equations; a single
// image (no right camera) gets the 6x6 system, the unused block the identity with a zero right-hand side.
void addPairConstraints(const Network& net, int32_t pair, Mat12& n, Vec12& b) {
  const NetPair& pr = net.pair(pair);
  const bool single = pr.right < 0;
  const NetImage& left = net.image(pr.left);
  const NetImage& right = net.image(single ? pr.left : pr.right);
  ConstraintRows rows;
  ConstraintJacobian jac;
  if (pairConstraintRows(net, pair, left.center_m, left.m, right.center_m, right.m, rows, jac) > 0) {
    n.noalias() += jac.transpose().lazyProduct(jac);  // coefficient-based: no GEMM kernel
    b.noalias() -= jac.transpose() * rows;
  }
  if (single) {
    // The unused block at the scale of the used one, so that tiny constraint sigmas do not make the 12x12
    // block look singular (its solution is zero whatever its scale).
    const double scale = std::max(n.block<6, 6>(0, 0).diagonal().maxCoeff(), 1.0);
    n.block<6, 6>(6, 6) = Mat6::Identity() * scale;
    n.block<6, 6>(0, 6).setZero();
    n.block<6, 6>(6, 0).setZero();
    b.segment<6>(6).setZero();
  }
}

// A pair's 12 EO unknowns (left 0-5, right 6-11; a single image leaves 6-11 at zero) in a per-image
// array of 6 values per image, and back.
Vec12 gatherPair(const NetPair& pr, const double* per_image) {
  Vec12 v = Vec12::Zero();
  v.head<6>() = Eigen::Map<const Vec6>(per_image + 6 * pr.left);
  if (pr.right >= 0) v.tail<6>() = Eigen::Map<const Vec6>(per_image + 6 * pr.right);
  return v;
}

void scatterPair(const NetPair& pr, const Vec12& v, double* per_image) {
  Eigen::Map<Vec6>(per_image + 6 * pr.left) = v.head<6>();
  if (pr.right >= 0) Eigen::Map<Vec6>(per_image + 6 * pr.right) = v.tail<6>();
}

}  // namespace

const char* stopRuleName(StopRule rule) {
  switch (rule) {
    case StopRule::kCostAndStep:
      return "cost_and_step";
    case StopRule::kMaxSweeps:
      return "max_sweeps";
    case StopRule::kNoDecrease:
      return "no_decrease";
    default:
      return "none";
  }
}

const char* fastMethodName(FastMethod method) {
  switch (method) {
    case FastMethod::kSchurPcg:
      return "schur_pcg";
    case FastMethod::kSchurCholesky:
      return "schur_cholesky";
    default:
      return "alternation";
  }
}

double eoPixelEquivalent(double f_px, const Vec3& d_center_m, double angle_rad, double nominal_range_m) {
  return f_px * (std::fabs(angle_rad) + d_center_m.norm() / nominal_range_m);
}

void FastAdjuster::buildImageIndex(const Network& net) {
  const int32_t n_img = net.imageCount();
  for (int32_t i = 0; i <= n_img; ++i) image_obs_start_[i] = 0;
  for (int32_t k = 0; k < net.observationCount(); ++k) ++image_obs_start_[net.observation(k).image + 1];
  for (int32_t i = 0; i < n_img; ++i) image_obs_start_[i + 1] += image_obs_start_[i];
  // Fill using image_obs_start_ shifted by one as running cursors, then restore.
  for (int32_t k = 0; k < net.observationCount(); ++k) {
    const int32_t img = net.observation(k).image;
    image_obs_[image_obs_start_[img]++] = k;
  }
  for (int32_t i = n_img; i > 0; --i) image_obs_start_[i] = image_obs_start_[i - 1];
  image_obs_start_[0] = 0;
}

Status FastAdjuster::checkNetwork(Network& net, int32_t& bad_image) {
  bad_image = -1;
  // Points: at least two active rays.
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    NetPoint& pt = net.point(p);
    int32_t active = 0;
    for (int32_t k = 0; k < pt.obs_count; ++k) active += net.observation(pt.obs[k]).rejected ? 0 : 1;
    if (active < 2) pt.solvable = false;
    if (!pt.xyz_m.allFinite()) pt.solvable = false;
  }
  buildImageIndex(net);
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    int32_t n = 0;
    Vec3 mean = Vec3::Zero();
    for (int32_t k = image_obs_start_[i]; k < image_obs_start_[i + 1]; ++k) {
      const NetObservation& o = net.observation(image_obs_[k]);
      if (!usable(net, o)) continue;
      mean += net.point(o.point).xyz_m;
      ++n;
    }
    if (n < kMinObservationsPerImage) {
      bad_image = i;
      return Status::kDegenerate;
    }
    mean /= static_cast<double>(n);
    Mat3 cov = Mat3::Zero();
    for (int32_t k = image_obs_start_[i]; k < image_obs_start_[i + 1]; ++k) {
      const NetObservation& o = net.observation(image_obs_[k]);
      if (!usable(net, o)) continue;
      const Vec3 d = net.point(o.point).xyz_m - mean;
      cov.noalias() += d * d.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Mat3> eig(cov, Eigen::EigenvaluesOnly);
    // All points on one line: the middle eigenvalue vanishes (1e-10 relative ~ 10 um spread over 1 m).
    if (!(eig.eigenvalues()(1) > 1e-10 * eig.eigenvalues()(2))) {
      bad_image = i;
      return Status::kDegenerate;
    }
  }
  return Status::kOk;
}

double FastAdjuster::evaluateCost(const Network& net, double* rms_px, int32_t* active) const {
  double cost = 0.0;
  double sq_px = 0.0;
  int32_t n = 0;
  for (int32_t k = 0; k < net.observationCount(); ++k) {
    const NetObservation& o = net.observation(k);
    if (!usable(net, o)) continue;
    const NetImage& im = net.image(o.image);
    Vec2 r;
    if (!ok(observationRow(o, im, im.center_m, im.m, net.point(o.point).xyz_m, r, nullptr, nullptr))) {
      cost += kBehindCameraCost;
      continue;
    }
    cost += r.squaredNorm();
    sq_px += r.squaredNorm() * o.sigma_px * o.sigma_px;
    ++n;
  }
  for (int32_t p = 0; p < net.pairCount(); ++p) {
    ConstraintRows rows;
    ConstraintJacobian jac;
    currentPairConstraintRows(net, p, rows, jac);
    cost += rows.squaredNorm();
  }
  if (rms_px != nullptr) *rms_px = n > 0 ? std::sqrt(sq_px / (2.0 * n)) : 0.0;
  if (active != nullptr) *active = n;
  return cost;
}

Status FastAdjuster::pairStep(Network& net, bool keep_normals) {
  for (int32_t p = 0; p < net.pairCount(); ++p) {
    const NetPair& pr = net.pair(p);
    const int32_t images[2] = {pr.left, pr.right};
    const int32_t sides = pr.right >= 0 ? 2 : 1;
    Mat12 n = Mat12::Zero();
    Vec12 b = Vec12::Zero();
    for (int32_t s = 0; s < sides; ++s) {
      const NetImage& im = net.image(images[s]);
      for (int32_t k = image_obs_start_[images[s]]; k < image_obs_start_[images[s] + 1]; ++k) {
        const NetObservation& o = net.observation(image_obs_[k]);
        if (!usable(net, o)) continue;
        Vec2 r;
        Mat2x6 j;
        if (!ok(observationRow(o, im, im.center_m, im.m, net.point(o.point).xyz_m, r, &j, nullptr))) continue;
        n.block<6, 6>(6 * s, 6 * s).noalias() += j.transpose() * j;
        b.segment<6>(6 * s).noalias() += j.transpose() * r;
      }
    }
    addPairConstraints(net, p, n, b);
    const Eigen::LDLT<Mat12> ldlt(n);
    const Vec12 d = ldlt.vectorD();
    if (ldlt.info() != Eigen::Success || !(d.minCoeff() > 1e-12 * d.maxCoeff())) {
      pair_normal_ok_[p] = false;
      return Status::kDegenerate;
    }
    if (keep_normals) {
      pair_normal_[p] = n;
      pair_normal_ok_[p] = true;
      continue;
    }
    const Vec12 delta = ldlt.solve(b);
    if (!delta.allFinite()) {
      return Status::kNotFinite;
    }
    for (int32_t s = 0; s < sides; ++s) {
      NetImage& im = net.image(images[s]);
      applyCameraUpdate(delta.segment<6>(6 * s), im.center_m, im.m);
    }
  }
  return Status::kOk;
}

void FastAdjuster::linearize(const Network& net) {
  // Whitened residual and Jacobians of every usable observation at the current state, in storage order.
  for (int32_t k = 0; k < net.observationCount(); ++k) {
    const NetObservation& o = net.observation(k);
    obs_valid_[k] = false;
    if (!usable(net, o)) continue;
    const NetImage& im = net.image(o.image);
    obs_valid_[k] = ok(observationRow(o, im, im.center_m, im.m, net.point(o.point).xyz_m, obs_residual_[k],
                                      &obs_d_image_[k], &obs_d_point_[k]));
  }
}

void FastAdjuster::pointBlocks(const Network& net, double damping) {
  // Every point's 3x3 normal block (Levenberg-damped by `damping`), its inverse and right-hand side over all
  // its rays, from the observation rows of the last linearize().
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    const NetPoint& pt = net.point(p);
    point_eliminated_[p] = false;
    mark_[p] = -1;
    if (!pt.solvable) continue;
    Mat3 n = Mat3::Zero();
    Vec3 b = Vec3::Zero();
    int32_t rays = 0;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const int32_t oi = pt.obs[k];
      if (!obs_valid_[oi]) continue;
      n.noalias() += obs_d_point_[oi].transpose() * obs_d_point_[oi];
      b.noalias() += obs_d_point_[oi].transpose() * obs_residual_[oi];
      ++rays;
    }
    if (rays < 2) continue;
    n.diagonal() *= 1.0 + damping;
    // Closed-form 3x3 inverse; parallel rays make the determinant vanish against the scale of n.
    const double scale = n.trace();
    if (!(n.determinant() > 1e-14 * scale * scale * scale)) continue;
    point_inverse_[p] = n.inverse();
    point_rhs_[p] = b;
    point_eliminated_[p] = true;
  }
}

int32_t FastAdjuster::pairBlock(const Network& net, int32_t pi, Mat12& n, Vec12& b, bool couple) {
  // The pair's 12x12 block and right-hand side from the cached rows and its constraints, and (couple) the
  // coupling W (12x3) to every eliminated point it sees (listed in touched_). Returns the number of such
  // points.
  const NetPair& pr = net.pair(pi);
  const int32_t images[2] = {pr.left, pr.right};
  const int32_t sides = pr.right >= 0 ? 2 : 1;
  n.setZero();
  b.setZero();
  int32_t n_touched = 0;
  for (int32_t s = 0; s < sides; ++s) {
    for (int32_t k = image_obs_start_[images[s]]; k < image_obs_start_[images[s] + 1]; ++k) {
      const int32_t index = image_obs_[k];
      const NetObservation& o = net.observation(index);
      if (!usable(net, o) || !obs_valid_[index]) continue;
      const Mat2x6& j = obs_d_image_[index];
      n.block<6, 6>(6 * s, 6 * s).noalias() += j.transpose() * j;
      b.segment<6>(6 * s).noalias() += j.transpose() * obs_residual_[index];
      if (!couple || !point_eliminated_[o.point]) continue;
      if (mark_[o.point] != pi) {
        mark_[o.point] = pi;
        coupling(o.point).setZero();
        touched_[n_touched++] = o.point;
      }
      coupling(o.point).block<6, 3>(6 * s, 0).noalias() += j.transpose() * obs_d_point_[index];
    }
  }
  addPairConstraints(net, pi, n, b);
  return n_touched;
}

void FastAdjuster::reducePairBlock(int32_t n_touched, Mat12& n, Vec12* b) const {
  for (int32_t t = 0; t < n_touched; ++t) {
    const int32_t p = touched_[t];
    Mat12x3 wn;
    wn.noalias() = coupling(p) * point_inverse_[p];
    n.noalias() -= wn.lazyProduct(coupling(p).transpose());
    if (b != nullptr) b->noalias() -= wn * point_rhs_[p];
  }
}

Status FastAdjuster::reducedSweep(Network& net) {
  linearize(net);
  pointBlocks(net, 0.0);
  // Pair after pair: the reduced 12x12 system, its solve, and the points' right-hand sides updated for the
  // pair's step (so that the next pair sees it: Gauss-Seidel on the reduced camera system).
  for (int32_t pi = 0; pi < net.pairCount(); ++pi) {
    Mat12 n;
    Vec12 b;
    const int32_t n_touched = pairBlock(net, pi, n, b, true);
    reducePairBlock(n_touched, n, &b);
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
    applyCameraUpdate(delta.head<6>(), net.image(pr.left).center_m, net.image(pr.left).m);
    if (pr.right >= 0) applyCameraUpdate(delta.tail<6>(), net.image(pr.right).center_m, net.image(pr.right).m);
    for (int32_t t = 0; t < n_touched; ++t) {
      const int32_t p = touched_[t];
      point_rhs_[p].noalias() -= coupling(p).transpose() * delta;
    }
  }
  // Back-substitution of the points (3x3).
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    if (point_eliminated_[p]) movePoint(net, net.point(p), point_inverse_[p] * point_rhs_[p]);
  }
  return Status::kOk;
}

void FastAdjuster::pointStep(Network& net) {
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
      if (!ok(observationRow(o, im, im.center_m, im.m, pt.xyz_m, r, nullptr, &j))) continue;
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

void FastAdjuster::readTangent(const Network& net, double* x) const {
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    const NetImage& im = net.image(i);
    Mat3 d;
    d.noalias() = im.m * im.m_apriori.transpose();
    const Vec3 c = im.center_m - im.center_apriori_m;
    const Vec3 w = rotationVector(d);
    for (int32_t k = 0; k < 3; ++k) {
      x[6 * i + k] = c(k);
      x[6 * i + 3 + k] = w(k);
    }
  }
}

void FastAdjuster::writeTangent(Network& net, const double* x) const {
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    NetImage& im = net.image(i);
    const Vec3 c(x[6 * i], x[6 * i + 1], x[6 * i + 2]);
    const Vec3 w(x[6 * i + 3], x[6 * i + 4], x[6 * i + 5]);
    im.center_m = im.center_apriori_m + c;
    im.m.noalias() = rotationFromVector(w) * im.m_apriori;
  }
}

bool FastAdjuster::andersonCandidate(int32_t dim, const double* g, double* candidate) {
  const int32_t m = hist_count_ - 1;  // number of differences
  if (m < 1) return false;
  const int32_t newest = hist_count_ - 1;
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

Status FastAdjuster::solve(Network& net, const FastAdjustOptions& options, FastAdjustResult& result) {
  const int32_t dim = 6 * net.imageCount();
  const int32_t max_sweeps = std::min(std::max(options.max_sweeps, 1), kMaxFastSweeps);
  const int32_t window = std::min(std::max(options.window, 1), kMaxStopWindow);
  depth_ = std::min(std::max(options.anderson_depth, 1), kMaxAndersonDepth);
  hist_count_ = 0;
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    const double f = net.image(i).io.f_px;
    for (int32_t k = 0; k < 3; ++k) {
      scale_[6 * i + k] = f / options.nominal_range_m;
      scale_[6 * i + 3 + k] = f;
    }
  }
  double cost_window[kMaxStopWindow + 1] = {};
  pointStep(net);
  double cost = evaluateCost(net);
  if (!std::isfinite(cost)) return Status::kNotFinite;
  readTangent(net, x_);
  result.stop_rule = StopRule::kMaxSweeps;
  result.sweeps = 0;
  for (int32_t sweep = 0; sweep < max_sweeps; ++sweep) {
    for (int32_t w = window; w > 0; --w) cost_window[w] = cost_window[w - 1];
    cost_window[0] = cost;
    const Status s = options.reduced_pair_solves ? reducedSweep(net) : pairStep(net, false);
    if (!ok(s)) return s;
    readTangent(net, g_);
    // Largest EO update of this plain sweep, pixel equivalent.
    double step_px = 0.0;
    for (int32_t i = 0; i < net.imageCount(); ++i) {
      const Vec3 dc(g_[6 * i] - x_[6 * i], g_[6 * i + 1] - x_[6 * i + 1], g_[6 * i + 2] - x_[6 * i + 2]);
      const Vec3 dw(g_[6 * i + 3] - x_[6 * i + 3], g_[6 * i + 4] - x_[6 * i + 4], g_[6 * i + 5] - x_[6 * i + 5]);
      step_px = std::max(step_px, eoPixelEquivalent(net.image(i).io.f_px, dc, dw.norm(), options.nominal_range_m));
    }
    // History of (F = G(x) - x, G(x)), oldest first.
    if (hist_count_ == depth_ + 1) {
      for (int32_t h = 0; h < depth_; ++h) {
        for (int32_t d = 0; d < dim; ++d) {
          hist_f_[h][d] = hist_f_[h + 1][d];
          hist_g_[h][d] = hist_g_[h + 1][d];
        }
      }
      --hist_count_;
    }
    for (int32_t d = 0; d < dim; ++d) {
      hist_f_[hist_count_][d] = g_[d] - x_[d];
      hist_g_[hist_count_][d] = g_[d];
    }
    ++hist_count_;

    bool accelerated = false;
    if (options.anderson && andersonCandidate(dim, g_, candidate_)) {
      writeTangent(net, candidate_);
      pointStep(net);
      const double c = evaluateCost(net);
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
      cost = evaluateCost(net);
      for (int32_t d = 0; d < dim; ++d) x_[d] = g_[d];
    }
    if (!std::isfinite(cost)) return Status::kNotFinite;
    result.sweeps = sweep + 1;
    ++result.sweeps_total;
    result.last_step_px = step_px;
    if (sweep < options.trace_capacity) {
      if (options.cost_trace != nullptr) options.cost_trace[sweep] = cost;
      if (options.step_trace != nullptr) options.step_trace[sweep] = step_px;
    }
    if (sweep + 1 >= window) {
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

void FastAdjuster::eliminatePoints(Network& net, double damping) {
  // Damped point blocks, the pairs' damped 12x12 blocks (kept in pair_normal_), their right-hand sides
  // (in pcg_r_, before the reduction) and their reduced inverses (the preconditioner), from the observation
  // rows of the last linearize().
  pointBlocks(net, damping);
  for (int32_t pi = 0; pi < net.pairCount(); ++pi) {
    const NetPair& pr = net.pair(pi);
    Mat12 n;
    Vec12 b;
    const int32_t n_touched = pairBlock(net, pi, n, b, true);
    n.diagonal() *= 1.0 + damping + 1e-12;
    pair_normal_[pi] = n;
    reducePairBlock(n_touched, n, nullptr);
    const Eigen::LDLT<Mat12> ldlt(n);
    pair_inverse_[pi] = ldlt.info() == Eigen::Success ? Mat12(ldlt.solve(Mat12::Identity())) : Mat12::Identity();
    if (!pair_inverse_[pi].allFinite()) pair_inverse_[pi].setIdentity();
    scatterPair(pr, b, pcg_r_);
  }
}

void FastAdjuster::reducedProduct(const Network& net, const double* x, double* y) const {
  // y = (C - W N^-1 W^T) x with C the pair blocks, through the cached observation rows.
  for (int32_t pi = 0; pi < net.pairCount(); ++pi) {
    const NetPair& pr = net.pair(pi);
    const Vec12 xx = gatherPair(pr, x);
    Vec12 yy;
    yy.noalias() = pair_normal_[pi] * xx;
    scatterPair(pr, yy, y);
  }
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    if (!point_eliminated_[p]) continue;
    const NetPoint& pt = net.point(p);
    Vec3 t = Vec3::Zero();
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const int32_t oi = pt.obs[k];
      if (net.observation(oi).rejected || !obs_valid_[oi]) continue;
      const Eigen::Map<const Vec6> xi(x + 6 * net.observation(oi).image);
      const Vec2 jx = obs_d_image_[oi] * xi;
      t.noalias() += obs_d_point_[oi].transpose() * jx;
    }
    const Vec3 u = point_inverse_[p] * t;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const int32_t oi = pt.obs[k];
      if (net.observation(oi).rejected || !obs_valid_[oi]) continue;
      Eigen::Map<Vec6> yi(y + 6 * net.observation(oi).image);
      const Vec2 ju = obs_d_point_[oi] * u;
      yi.noalias() -= obs_d_image_[oi].transpose() * ju;
    }
  }
}

void FastAdjuster::pcgStep(Network& net, const FastAdjustOptions& options, double damping,
                           FastAdjustResult& result) {
  // The LM step (cameras in pcg_x_) by preconditioned conjugate gradients on the reduced camera system.
  const int32_t dim = 6 * net.imageCount();
  eliminatePoints(net, damping);
  // Right-hand side of the reduced camera system: v = g - W N^-1 b (pcg_r_ holds g on entry).
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    if (!point_eliminated_[p]) continue;
    const NetPoint& pt = net.point(p);
    const Vec3 u = point_inverse_[p] * point_rhs_[p];
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const int32_t oi = pt.obs[k];
      if (!obs_valid_[oi]) continue;
      Eigen::Map<Vec6> ri(pcg_r_ + 6 * net.observation(oi).image);
      const Vec2 ju = obs_d_point_[oi] * u;
      ri.noalias() -= obs_d_image_[oi].transpose() * ju;
    }
  }
  // Preconditioned conjugate gradients from x = 0.
  double rhs_norm2 = 0.0;
  for (int32_t d = 0; d < dim; ++d) {
    pcg_x_[d] = 0.0;
    rhs_norm2 += pcg_r_[d] * pcg_r_[d];
  }
  double rz = 0.0;
  for (int32_t stage = 0; stage < kMaxPcgIterations; ++stage) {
    // z = P^-1 r (per pair).
    for (int32_t pi = 0; pi < net.pairCount(); ++pi) {
      const NetPair& pr = net.pair(pi);
      const Vec12 zz = pair_inverse_[pi] * gatherPair(pr, pcg_r_);
      scatterPair(pr, zz, pcg_z_);
    }
    double rz_new = 0.0;
    for (int32_t d = 0; d < dim; ++d) rz_new += pcg_r_[d] * pcg_z_[d];
    const double beta = stage == 0 ? 0.0 : rz_new / rz;
    rz = rz_new;
    for (int32_t d = 0; d < dim; ++d) pcg_p_[d] = pcg_z_[d] + beta * pcg_p_[d];
    reducedProduct(net, pcg_p_, pcg_q_);
    double pq = 0.0;
    for (int32_t d = 0; d < dim; ++d) pq += pcg_p_[d] * pcg_q_[d];
    if (!(pq > 0.0)) break;
    const double alpha = rz / pq;
    double r2 = 0.0;
    for (int32_t d = 0; d < dim; ++d) {
      pcg_x_[d] += alpha * pcg_p_[d];
      pcg_r_[d] -= alpha * pcg_q_[d];
      r2 += pcg_r_[d] * pcg_r_[d];
    }
    ++result.pcg_iterations;
    if (r2 <= options.pcg_relative_tolerance * options.pcg_relative_tolerance * rhs_norm2) break;
  }
}

bool FastAdjuster::orderPairs(const Network& net) {
  // The pair graph (two pairs are adjacent when they observe a common solvable point), a minimum-degree
  // elimination order of it (ties: the lower pair index, i.e. the panorama order) and the block pattern of
  // the Cholesky factor in that order, fill included (the elimination graph). False when the factor needs
  // more than kMaxFactorBlocks blocks.
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

bool FastAdjuster::assembleAndFactor(const Network& net, double damping) {
  // The damped reduced camera system S = C - W N^-1 W^T (rhs v = g - W N^-1 b) in 12x12 pair blocks of the
  // factor's pattern, then its block Cholesky factor L (S = L L^T) in place. False when S is not positive
  // definite at this damping.
  const int32_t n = net.pairCount();
  pointBlocks(net, damping);
  for (int32_t d = 0; d < 144 * factor_blocks_; ++d) shared_[d] = 0.0;
  for (int32_t pi = 0; pi < n; ++pi) {
    Mat12 c;
    Vec12 g;
    (void)pairBlock(net, pi, c, g, false);
    c.diagonal() *= 1.0 + damping + 1e-12;
    const int32_t q = position_[pi];
    factorBlock(q, q) = c;
    Eigen::Map<Vec12>(rcs_b_ + 12 * q) = g;
  }
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    if (!point_eliminated_[p]) continue;
    const NetPoint& pt = net.point(p);
    Mat6x3 w[kMaxObsPerPoint];
    Mat6x3 t[kMaxObsPerPoint];
    int32_t block[kMaxObsPerPoint];
    int32_t offset[kMaxObsPerPoint];
    int32_t count = 0;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const int32_t oi = pt.obs[k];
      if (!obs_valid_[oi]) continue;
      const NetImage& im = net.image(net.observation(oi).image);
      w[count].noalias() = obs_d_image_[oi].transpose() * obs_d_point_[oi];
      t[count].noalias() = w[count] * point_inverse_[p];
      block[count] = position_[im.pair];
      offset[count] = im.side == Side::kLeft ? 0 : 6;
      Eigen::Map<Vec12>(rcs_b_ + 12 * block[count]).segment<6>(offset[count]).noalias() -= t[count] * point_rhs_[p];
      ++count;
    }
    for (int32_t a = 0; a < count; ++a) {
      for (int32_t b = 0; b < count; ++b) {
        if (block[a] < block[b]) continue;  // the lower triangle only
        factorBlock(block[a], block[b]).block<6, 6>(offset[a], offset[b]).noalias() -=
            t[a].lazyProduct(w[b].transpose());
      }
    }
  }
  // Right-looking block Cholesky.
  for (int32_t k = 0; k < n; ++k) {
    Eigen::Map<Mat12, Eigen::Aligned16> lkk = factorBlock(k, k);
    const Eigen::LLT<Mat12> llt(lkk);
    if (llt.info() != Eigen::Success) return false;
    lkk = llt.matrixL();
    const Vec12 diag = lkk.diagonal();
    if (!diag.allFinite() || !(diag.minCoeff() > 1e-9 * diag.maxCoeff())) return false;
    for (int32_t r = col_start_[k]; r < col_start_[k + 1]; ++r) {
      Eigen::Map<Mat12, Eigen::Aligned16> lik = factorBlock(col_rows_[r], k);
      lkk.triangularView<Eigen::Lower>().transpose().solveInPlace<Eigen::OnTheRight>(lik);  // L_ik L_kk^T = S_ik
    }
    for (int32_t r = col_start_[k]; r < col_start_[k + 1]; ++r) {
      const int32_t i = col_rows_[r];
      const Eigen::Map<const Mat12, Eigen::Aligned16> lik(shared_ + 144 * block_pos_[i][k]);
      for (int32_t c = col_start_[k]; c < col_start_[k + 1]; ++c) {
        const int32_t j = col_rows_[c];
        if (j > i) continue;
        const Eigen::Map<const Mat12, Eigen::Aligned16> ljk(shared_ + 144 * block_pos_[j][k]);
        factorBlock(i, j).noalias() -= lik.lazyProduct(ljk.transpose());
      }
    }
  }
  return true;
}

void FastAdjuster::solveFactor(const Network& net) {
  // L L^T x = v by block forward and back substitution; the cameras' step into pcg_x_ (per image).
  const int32_t n = net.pairCount();
  for (int32_t k = 0; k < n; ++k) {
    Eigen::Map<Vec12> bk(rcs_b_ + 12 * k);
    factorBlock(k, k).triangularView<Eigen::Lower>().solveInPlace(bk);
    for (int32_t r = col_start_[k]; r < col_start_[k + 1]; ++r) {
      Eigen::Map<Vec12>(rcs_b_ + 12 * col_rows_[r]).noalias() -= factorBlock(col_rows_[r], k) * bk;
    }
  }
  for (int32_t k = n - 1; k >= 0; --k) {
    Eigen::Map<Vec12> bk(rcs_b_ + 12 * k);
    for (int32_t r = col_start_[k]; r < col_start_[k + 1]; ++r) {
      bk.noalias() -= factorBlock(col_rows_[r], k).transpose() * Eigen::Map<const Vec12>(rcs_b_ + 12 * col_rows_[r]);
    }
    factorBlock(k, k).triangularView<Eigen::Lower>().transpose().solveInPlace(bk);
  }
  for (int32_t pi = 0; pi < n; ++pi) {
    const NetPair& pr = net.pair(pi);
    scatterPair(pr, Eigen::Map<const Vec12>(rcs_b_ + 12 * position_[pi]), pcg_x_);
  }
}

Status FastAdjuster::solveLm(Network& net, const FastAdjustOptions& options, FastAdjustResult& result) {
  bool direct = options.method == FastMethod::kSchurCholesky;
  if (direct && !orderPairs(net)) {
    direct = false;
    result.cholesky_fallback = true;
  }
  result.factor_blocks = direct ? factor_blocks_ : 0;
  const int32_t max_iterations = std::min(std::max(options.max_sweeps, 1), kMaxFastSweeps);
  // The exact (direct) step converges quadratically: one accepted step is the window.
  const int32_t window = direct ? 1 : std::min(std::max(options.window, 1), kMaxStopWindow);
  double cost_window[kMaxStopWindow + 1] = {};
  double cost = evaluateCost(net);
  if (!std::isfinite(cost)) return Status::kNotFinite;
  double damping = 1e-4;
  constexpr double kMaxDamping = 1e12;
  constexpr double kMinDamping = 1e-12;
  int32_t accepted = 0;
  bool stale = true;  // the observation rows do not belong to the current state
  result.stop_rule = StopRule::kMaxSweeps;
  for (int32_t it = 0; it < max_iterations; ++it) {
    result.sweeps = it + 1;
    ++result.sweeps_total;
    if (stale) {
      linearize(net);
      stale = false;
    }
    if (direct) {
      ++result.factorisations;
      if (!assembleAndFactor(net, damping)) {
        damping *= 10.0;  // not positive definite at this damping
        if (damping > kMaxDamping) {
          result.stop_rule = StopRule::kNoDecrease;
          break;
        }
        continue;
      }
      solveFactor(net);
    } else {
      pcgStep(net, options, damping, result);
    }
    // Save, apply the step (cameras, then back-substituted points), and keep it only if the cost drops.
    for (int32_t i = 0; i < net.imageCount(); ++i) {
      saved_center_[i] = net.image(i).center_m;
      saved_m_[i] = net.image(i).m;
    }
    for (int32_t p = 0; p < net.pointCount(); ++p) saved_xyz_[p] = net.point(p).xyz_m;
    double step_px = 0.0;
    for (int32_t i = 0; i < net.imageCount(); ++i) {
      NetImage& im = net.image(i);
      const Eigen::Map<const Vec6> d(pcg_x_ + 6 * i);
      step_px = std::max(step_px, eoPixelEquivalent(im.io.f_px, d.head<3>(), d.tail<3>().norm(),
                                                    options.nominal_range_m));
      applyCameraUpdate(d, im.center_m, im.m);
    }
    for (int32_t p = 0; p < net.pointCount(); ++p) {
      if (!point_eliminated_[p]) continue;
      NetPoint& pt = net.point(p);
      Vec3 b = point_rhs_[p];
      for (int32_t k = 0; k < pt.obs_count; ++k) {
        const int32_t oi = pt.obs[k];
        if (!obs_valid_[oi]) continue;
        const Eigen::Map<const Vec6> xi(pcg_x_ + 6 * net.observation(oi).image);
        const Vec2 jx = obs_d_image_[oi] * xi;
        b.noalias() -= obs_d_point_[oi].transpose() * jx;
      }
      movePoint(net, pt, point_inverse_[p] * b);
    }
    const double new_cost = evaluateCost(net);
    if (std::isfinite(new_cost) && new_cost < cost) {
      for (int32_t w = window; w > 0; --w) cost_window[w] = cost_window[w - 1];
      cost_window[0] = cost;
      cost = new_cost;
      ++accepted;
      stale = true;
      damping = std::max(damping * 0.1, kMinDamping);
      result.last_step_px = step_px;
      if (it < options.trace_capacity) {
        if (options.cost_trace != nullptr) options.cost_trace[it] = cost;
        if (options.step_trace != nullptr) options.step_trace[it] = step_px;
      }
      const double window_decrease = cost_window[window - 1] - cost;  // accepted steps only lower the cost
      if (accepted >= window && window_decrease <= options.relative_cost_tolerance * cost &&
          step_px < options.eo_step_tolerance_px) {
        result.stop_rule = StopRule::kCostAndStep;
        break;
      }
    } else {
      for (int32_t i = 0; i < net.imageCount(); ++i) {
        net.image(i).center_m = saved_center_[i];
        net.image(i).m = saved_m_[i];
      }
      for (int32_t p = 0; p < net.pointCount(); ++p) net.point(p).xyz_m = saved_xyz_[p];
      // A tiny exact step that does not lower the cost: the minimum, to rounding.
      if (direct && accepted > 0 && step_px < options.eo_step_tolerance_px &&
          std::isfinite(new_cost) && new_cost - cost <= options.relative_cost_tolerance * cost) {
        result.stop_rule = StopRule::kCostAndStep;
        break;
      }
      damping *= 10.0;
      if (damping > kMaxDamping) {
        result.stop_rule = StopRule::kNoDecrease;
        break;
      }
    }
  }
  return Status::kOk;
}

int32_t FastAdjuster::rejectOutliers(Network& net, const FastAdjustOptions& options) {
  int32_t n = 0;
  for (int32_t k = 0; k < net.observationCount(); ++k) {
    const NetObservation& o = net.observation(k);
    if (!usable(net, o)) continue;
    const NetImage& im = net.image(o.image);
    Vec2 r;
    if (!ok(observationRow(o, im, im.center_m, im.m, net.point(o.point).xyz_m, r, nullptr, nullptr))) continue;
    scratch_[n++] = std::fabs(r.x());
    scratch_[n++] = std::fabs(r.y());
  }
  if (n == 0) return 0;
  std::nth_element(scratch_, scratch_ + n / 2, scratch_ + n);
  const double robust_sigma = 1.4826 * scratch_[n / 2];
  const double threshold = std::max(options.reject_k * robust_sigma, options.reject_floor_sigma);
  int32_t rejected = 0;
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    NetPoint& pt = net.point(p);
    if (!pt.solvable) continue;
    int32_t worst = -1;
    double worst_norm = threshold;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const NetObservation& o = net.observation(pt.obs[k]);
      if (o.rejected) continue;
      const NetImage& im = net.image(o.image);
      Vec2 r;
      const Status s = observationRow(o, im, im.center_m, im.m, pt.xyz_m, r, nullptr, nullptr);
      const double norm = ok(s) ? r.norm() : 1e300;  // a ray behind its camera is an outlier too
      if (norm > worst_norm) {
        worst_norm = norm;
        worst = pt.obs[k];
      }
    }
    if (worst >= 0) {
      net.observation(worst).rejected = true;
      ++rejected;
      if (!ok(net.triangulate(p))) pt.solvable = false;
    }
  }
  return rejected;
}

Status FastAdjuster::adjust(Network& net, const FastAdjustOptions& options, FastAdjustResult& result) {
  result = FastAdjustResult{};
  if (net.imageCount() == 0) {
    result.status = Status::kMissingField;
    return result.status;
  }
  const bool alternation = options.method == FastMethod::kAlternation;
  for (int32_t round = 0; round <= kMaxRejectionRounds; ++round) {
    Status s = checkNetwork(net, result.degenerate_image);
    if (ok(s)) s = alternation ? solve(net, options, result) : solveLm(net, options, result);
    if (!ok(s)) {
      result.status = s;
      return s;
    }
    if (!options.robust || round == kMaxRejectionRounds) break;
    const int32_t rejected = rejectOutliers(net, options);
    if (rejected == 0) break;
    result.rejected_observations += rejected;
    ++result.rejection_rounds;
  }
  // Held rig sigmas (Network.hpp): solved again, warm, with a tighter sigma while a held constraint's misfit
  // exceeds half its bound.
  for (int32_t t = 0; t < kMaxRigTightenings && tightenHeldSigmas(net.rig, networkMisfit(net)); ++t) {
    ++result.rig_tightenings;
    const Status s = alternation ? solve(net, options, result) : solveLm(net, options, result);
    if (!ok(s)) {
      result.status = s;
      return s;
    }
  }
  // Precision: sigma naught from the redundancy, EO sigmas from the pair normal matrices (points fixed).
  const Status s = pairStep(net, true);
  if (!ok(s)) {
    result.status = s;
    return s;
  }
  result.cost = evaluateCost(net, &result.rms_px, &result.active_observations);
  int32_t constraint_rows = 0;
  for (int32_t p = 0; p < net.pairCount(); ++p) {
    const NetPair& pr = net.pair(p);
    ConstraintRows rows;
    ConstraintJacobian jac;
    constraint_rows += currentPairConstraintRows(net, p, rows, jac);
    if (net.rig.use_datum_prior) constraint_rows -= 3 * (pr.right >= 0 ? 2 : 1);
  }
  result.max_misfit = networkMisfit(net);
  result.held_rig_met = heldConstraintsMet(net.rig, result.max_misfit);
  int32_t points = 0;
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    if (net.point(p).solvable) {
      ++points;
    } else {
      ++result.unsolvable_points;
    }
  }
  // The prior fixes the datum's 3 rotations; it is not counted as observations.
  result.redundancy = 2 * result.active_observations + constraint_rows - 6 * net.imageCount() - 3 * points +
                      (net.rig.use_datum_prior ? 3 : 0);
  result.sigma0 = result.redundancy > 0 ? std::sqrt(result.cost / result.redundancy) : 0.0;
  for (int32_t p = 0; p < net.pairCount(); ++p) {
    const NetPair& pr = net.pair(p);
    const Eigen::LDLT<Mat12> ldlt(pair_normal_[p]);
    const Mat12 cov = ldlt.solve(Mat12::Identity());
    net.image(pr.left).sigma = result.sigma0 * cov.diagonal().head<6>().cwiseSqrt();
    if (pr.right >= 0) net.image(pr.right).sigma = result.sigma0 * cov.diagonal().tail<6>().cwiseSqrt();
  }
  result.status = Status::kOk;
  return Status::kOk;
}

}  // namespace areomap
