#include "firmware_core/adjust/ReducedCameraSystem.hpp"

#include <algorithm>
#include <cmath>

#include "firmware_core/adjust/Constraints.hpp"

namespace areomap {

namespace {

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
    if (!(im.m.row(2).dot(xyz - im.centre_m) < 0.0)) return false;
  }
  return true;
}

}  // namespace

bool usableObservation(const Network& net, const NetObservation& o) {
  return !o.rejected && net.point(o.point).solvable;
}

Status currentResidual(const Network& net, const NetObservation& o, Vec2& residual) {
  const NetImage& im = net.image(o.image);
  return observationRow(o, im, im.centre_m, im.m, net.point(o.point).xyz_m, residual, nullptr, nullptr);
}

double weightedCost(const Network& net, double* rms_px, int32_t* active) {
  double cost = 0.0;
  double sq_px = 0.0;
  int32_t n = 0;
  for (int32_t k = 0; k < net.observationCount(); ++k) {
    const NetObservation& o = net.observation(k);
    if (!usableObservation(net, o)) continue;
    Vec2 r;
    if (!ok(currentResidual(net, o, r))) {
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

void addPairConstraints(const Network& net, int32_t pair, Mat12& n, Vec12& b) {
  const NetPair& pr = net.pair(pair);
  const bool single = pr.right < 0;
  const NetImage& left = net.image(pr.left);
  const NetImage& right = net.image(single ? pr.left : pr.right);
  ConstraintRows rows;
  ConstraintJacobian jac;
  if (pairConstraintRows(net, pair, left.centre_m, left.m, right.centre_m, right.m, rows, jac) > 0) {
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

Status pairStep(Network& net, AdjustWorkspace& ws) {
  for (int32_t p = 0; p < net.pairCount(); ++p) {
    const NetPair& pr = net.pair(p);
    const int32_t images[2] = {pr.left, pr.right};
    const int32_t sides = pr.right >= 0 ? 2 : 1;
    Mat12 n = Mat12::Zero();
    Vec12 b = Vec12::Zero();
    for (int32_t s = 0; s < sides; ++s) {
      const NetImage& im = net.image(images[s]);
      for (int32_t k = ws.image_obs_start[images[s]]; k < ws.image_obs_start[images[s] + 1]; ++k) {
        const NetObservation& o = net.observation(ws.image_obs[k]);
        if (!usableObservation(net, o)) continue;
        Vec2 r;
        Mat2x6 j;
        if (!ok(observationRow(o, im, im.centre_m, im.m, net.point(o.point).xyz_m, r, &j, nullptr))) continue;
        n.block<6, 6>(6 * s, 6 * s).noalias() += j.transpose() * j;
        b.segment<6>(6 * s).noalias() += j.transpose() * r;
      }
    }
    addPairConstraints(net, p, n, b);
    const Eigen::LDLT<Mat12> ldlt(n);
    const Vec12 d = ldlt.vectorD();
    if (ldlt.info() != Eigen::Success || !(d.minCoeff() > 1e-12 * d.maxCoeff())) return Status::kDegenerate;
    const Vec12 delta = ldlt.solve(b);
    if (!delta.allFinite()) {
      return Status::kNotFinite;
    }
    for (int32_t s = 0; s < sides; ++s) {
      NetImage& im = net.image(images[s]);
      applyCameraUpdate(delta.segment<6>(6 * s), im.centre_m, im.m);
    }
  }
  return Status::kOk;
}

void linearize(const Network& net, AdjustWorkspace& ws) {
  // In storage order.
  for (int32_t k = 0; k < net.observationCount(); ++k) {
    const NetObservation& o = net.observation(k);
    ws.obs_valid[k] = false;
    if (!usableObservation(net, o)) continue;
    const NetImage& im = net.image(o.image);
    ws.obs_valid[k] = ok(observationRow(o, im, im.centre_m, im.m, net.point(o.point).xyz_m,
                                        ws.obs_residual[k], &ws.obs_d_image[k], &ws.obs_d_point[k]));
  }
}

void pointBlocks(const Network& net, AdjustWorkspace& ws, double damping) {
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    const NetPoint& pt = net.point(p);
    ws.point_eliminated[p] = false;
    ws.mark[p] = -1;
    if (!pt.solvable) continue;
    Mat3 n = Mat3::Zero();
    Vec3 b = Vec3::Zero();
    int32_t rays = 0;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const int32_t oi = pt.obs[k];
      if (!ws.obs_valid[oi]) continue;
      n.noalias() += ws.obs_d_point[oi].transpose() * ws.obs_d_point[oi];
      b.noalias() += ws.obs_d_point[oi].transpose() * ws.obs_residual[oi];
      ++rays;
    }
    if (rays < 2) continue;
    n.diagonal() *= 1.0 + damping;
    // Closed-form 3x3 inverse; parallel rays make the determinant vanish against the scale of n.
    const double scale = n.trace();
    if (!(n.determinant() > 1e-14 * scale * scale * scale)) continue;
    ws.point_inverse[p] = n.inverse();
    ws.point_rhs[p] = b;
    ws.point_eliminated[p] = true;
  }
}

int32_t pairBlock(const Network& net, AdjustWorkspace& ws, int32_t pi, Mat12& n, Vec12& b, bool couple) {
  const NetPair& pr = net.pair(pi);
  const int32_t images[2] = {pr.left, pr.right};
  const int32_t sides = pr.right >= 0 ? 2 : 1;
  n.setZero();
  b.setZero();
  int32_t n_touched = 0;
  for (int32_t s = 0; s < sides; ++s) {
    for (int32_t k = ws.image_obs_start[images[s]]; k < ws.image_obs_start[images[s] + 1]; ++k) {
      const int32_t index = ws.image_obs[k];
      const NetObservation& o = net.observation(index);
      if (!usableObservation(net, o) || !ws.obs_valid[index]) continue;
      const Mat2x6& j = ws.obs_d_image[index];
      n.block<6, 6>(6 * s, 6 * s).noalias() += j.transpose() * j;
      b.segment<6>(6 * s).noalias() += j.transpose() * ws.obs_residual[index];
      if (!couple || !ws.point_eliminated[o.point]) continue;
      if (ws.mark[o.point] != pi) {
        ws.mark[o.point] = pi;
        ws.coupling(o.point).setZero();
        ws.touched[n_touched++] = o.point;
      }
      ws.coupling(o.point).block<6, 3>(6 * s, 0).noalias() += j.transpose() * ws.obs_d_point[index];
    }
  }
  addPairConstraints(net, pi, n, b);
  return n_touched;
}

void reducePairBlock(const AdjustWorkspace& ws, int32_t n_touched, Mat12& n, Vec12* b) {
  for (int32_t t = 0; t < n_touched; ++t) {
    const int32_t p = ws.touched[t];
    Mat12x3 wn;
    wn.noalias() = ws.coupling(p) * ws.point_inverse[p];
    n.noalias() -= wn.lazyProduct(ws.coupling(p).transpose());
    if (b != nullptr) b->noalias() -= wn * ws.point_rhs[p];
  }
}

void reduceRightHandSide(const Network& net, const AdjustWorkspace& ws, double* v) {
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    if (!ws.point_eliminated[p]) continue;
    const NetPoint& pt = net.point(p);
    const Vec3 u = ws.point_inverse[p] * ws.point_rhs[p];
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const int32_t oi = pt.obs[k];
      if (!ws.obs_valid[oi]) continue;
      Eigen::Map<Vec6> ri(v + 6 * net.observation(oi).image);
      const Vec2 ju = ws.obs_d_point[oi] * u;
      ri.noalias() -= ws.obs_d_image[oi].transpose() * ju;
    }
  }
}

void reducedProduct(const Network& net, const AdjustWorkspace& ws, const double* x, double* y) {
  for (int32_t pi = 0; pi < net.pairCount(); ++pi) {
    const NetPair& pr = net.pair(pi);
    const Vec12 xx = gatherPair(pr, x);
    Vec12 yy;
    yy.noalias() = ws.pair_normal[pi] * xx;
    scatterPair(pr, yy, y);
  }
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    if (!ws.point_eliminated[p]) continue;
    const NetPoint& pt = net.point(p);
    Vec3 t = Vec3::Zero();
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const int32_t oi = pt.obs[k];
      if (net.observation(oi).rejected || !ws.obs_valid[oi]) continue;
      const Eigen::Map<const Vec6> xi(x + 6 * net.observation(oi).image);
      const Vec2 jx = ws.obs_d_image[oi] * xi;
      t.noalias() += ws.obs_d_point[oi].transpose() * jx;
    }
    const Vec3 u = ws.point_inverse[p] * t;
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const int32_t oi = pt.obs[k];
      if (net.observation(oi).rejected || !ws.obs_valid[oi]) continue;
      Eigen::Map<Vec6> yi(y + 6 * net.observation(oi).image);
      const Vec2 ju = ws.obs_d_point[oi] * u;
      yi.noalias() -= ws.obs_d_image[oi].transpose() * ju;
    }
  }
}

void backSubstitutePoints(Network& net, const AdjustWorkspace& ws, const double* camera_step) {
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    if (!ws.point_eliminated[p]) continue;
    NetPoint& pt = net.point(p);
    Vec3 b = ws.point_rhs[p];
    for (int32_t k = 0; k < pt.obs_count; ++k) {
      const int32_t oi = pt.obs[k];
      if (!ws.obs_valid[oi]) continue;
      const Eigen::Map<const Vec6> xi(camera_step + 6 * net.observation(oi).image);
      const Vec2 jx = ws.obs_d_image[oi] * xi;
      b.noalias() -= ws.obs_d_point[oi].transpose() * jx;
    }
    movePoint(net, pt, ws.point_inverse[p] * b);
  }
}

}  // namespace areomap
