#include "firmware_core/dem/CoarseDemRegistration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>

#include "firmware_core/base/Angles.hpp"

namespace areomap {
namespace {

int32_t stepsFor(double half_width, double step) {
  const int32_t n = static_cast<int32_t>(std::lround(half_width / step));
  return std::max(1, std::min(n, kMaxRegistrationSteps));
}

LevelledPose shiftedPose(const LevelledPose& base, double dx, double dy, double dh) {
  LevelledPose p = base;
  p.translation_m.x() += dx;
  p.translation_m.y() += dy;
  p.heading_rad += dh;
  return p;
}

}  // namespace

Mat3 LevelledPose::rotation() const {
  const double c = std::cos(heading_rad), s = std::sin(heading_rad);
  Mat3 r;
  r << c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0;
  return r;
}

const char* demRegistrationStatusName(DemRegistrationStatus status) {
  switch (status) {
    case DemRegistrationStatus::kOk:
      return "ok";
    case DemRegistrationStatus::kNoOverlap:
      return "no_overlap";
    case DemRegistrationStatus::kAmbiguous:
      return "ambiguous";
    case DemRegistrationStatus::kNotConverged:
      return "not_converged";
  }
  return "unknown";
}

// The differences A's elevation minus B's sample moved into A (Z down: e_a - z), over every stride-th sample
// that lands on A's DEM within range of A's origin.
CoarseDemRegistration::Moments CoarseDemRegistration::moments(const CoarseDem& a, const LevelledPose& pose,
                                                              double max_range_m, int32_t stride) const {
  Moments m;
  const Mat3 r = pose.rotation();
  const double r2 = max_range_m * max_range_m;
  for (int32_t i = 0; i < sample_count_; i += stride) {
    const Vec3 b(sample_[i][0], sample_[i][1], sample_[i][2]);
    const Vec3 p = r * b + pose.translation_m;
    if (p.x() * p.x() + p.y() * p.y() > r2) continue;
    double e = 0.0;
    if (!a.elevationAt(p.x(), p.y(), e)) continue;
    const double d = e - p.z();
    m.sum += d;
    m.sum2 += d * d;
    ++m.n;
  }
  return m;
}

// Gauss-Newton on A's DEM gradients (central differences over one cell), the samples beyond 3 robust sigmas
// of the differences trimmed once the threshold has settled (after 4 steps).
bool CoarseDemRegistration::gaussNewton(const CoarseDem& a, const DemRegistrationParams& params, int32_t min_used,
                                        LevelledPose& pose, DemRegistrationResult& out) {
  const double h = CoarseDem::cellSize();
  const double r2 = params.max_range_m * params.max_range_m;
  double trim = std::numeric_limits<double>::infinity();
  for (int32_t it = 0; it < kMaxRegistrationIterations; ++it) {
    RegMat4 normal = RegMat4::Zero();
    RegVec4 rhs = RegVec4::Zero();
    double rr = 0.0;
    int32_t n = 0, total = 0;
    const Mat3 r = pose.rotation();
    for (int32_t i = 0; i < sample_count_; ++i) {
      const Vec3 rb = r * Vec3(sample_[i][0], sample_[i][1], sample_[i][2]);
      const Vec3 p = rb + pose.translation_m;
      if (p.x() * p.x() + p.y() * p.y() > r2) continue;
      double e = 0.0, xp = 0.0, xm = 0.0, yp = 0.0, ym = 0.0;
      if (!a.elevationAt(p.x(), p.y(), e) || !a.elevationAt(p.x() + h, p.y(), xp) ||
          !a.elevationAt(p.x() - h, p.y(), xm) || !a.elevationAt(p.x(), p.y() + h, yp) ||
          !a.elevationAt(p.x(), p.y() - h, ym)) {
        continue;
      }
      const double ex = (xp - xm) / (2.0 * h), ey = (yp - ym) / (2.0 * h);
      const double d = e - p.z();
      abs_difference_[total++] = static_cast<float>(std::fabs(d));
      if (std::fabs(d) > trim) continue;
      // d(x + dx) ~ d + ex dx + ey dy - dz + (ex (-rb_y) + ey rb_x) dh
      const RegVec4 j(ex, ey, -1.0, ex * -rb.y() + ey * rb.x());
      normal.noalias() += j * j.transpose();
      rhs.noalias() += j * d;
      rr += d * d;
      ++n;
    }
    if (n < min_used) return false;
    out.overlap = total;
    out.used = n;
    out.iterations = it + 1;
    out.rms_m = std::sqrt(rr / n);
    const Eigen::LDLT<RegMat4> ldlt(normal);
    // No slope to fix x, y or the heading (flat ground): the pose is not determined.
    if (!(ldlt.vectorD().minCoeff() > 1e-9 * n)) return false;
    const RegVec4 delta = -ldlt.solve(rhs);
    if (!delta.allFinite()) return false;
    pose.translation_m += delta.head<3>();
    pose.heading_rad += delta[3];
    if (it < 4) {
      float* mid = abs_difference_ + total / 2;
      std::nth_element(abs_difference_, mid, abs_difference_ + total);
      trim = std::max(3.0 * 1.4826 * static_cast<double>(*mid), 0.02);
    }
    if (it >= 4 && delta.head<3>().norm() < 1e-3 && std::fabs(delta[3]) < 2e-5) {
      const double s0 = std::sqrt(rr / std::max(1, n - 4));
      const RegMat4 cov = ldlt.solve(RegMat4::Identity()) * s0 * s0;
      for (int32_t k = 0; k < 4; ++k) out.sigma[k] = std::sqrt(std::max(0.0, cov(k, k)));
      return true;
    }
  }
  out.status = DemRegistrationStatus::kNotConverged;
  return true;
}

// Long because: the steps of one registration in order (samples, overlap, grid search, second minimum,
// Gauss-Newton, the verdict), each short, sharing the grid's indices.
DemRegistrationResult CoarseDemRegistration::run(const CoarseDem& a, const CoarseDem& b, const LevelledPose& apriori,
                                                 const DemRegistrationParams& params) {
  DemRegistrationResult out;
  out.a_from_b = apriori;
  // B's samples: every cell with a value within range of B's origin, at its centre.
  sample_count_ = 0;
  const double cell = CoarseDem::cellSize();
  const Vec3 origin = b.origin();
  for (int32_t r = 0; r < CoarseDem::cells(); ++r) {
    for (int32_t c = 0; c < CoarseDem::cells(); ++c) {
      double z = 0.0;
      if (!b.cellValue(r, c, z)) continue;
      const double x = origin.x() + (r + 0.5) * cell, y = origin.y() + (c + 0.5) * cell;
      if (x * x + y * y > params.max_range_m * params.max_range_m) continue;
      sample_[sample_count_][0] = static_cast<float>(x);
      sample_[sample_count_][1] = static_cast<float>(y);
      sample_[sample_count_][2] = static_cast<float>(z);
      ++sample_count_;
    }
  }
  const Moments at_apriori = moments(a, apriori, params.max_range_m, 1);
  out.overlap = at_apriori.n;
  if (at_apriori.n < params.min_overlap_cells) return out;

  // Grid search: steps of one cell and one degree, the variance of the differences at each pose, over every
  // fourth sample (the search's cost is its poses times its samples; the fit below takes them all).
  constexpr int32_t kStride = 4;
  const int32_t nxy = stepsFor(params.search_m, cell);
  const int32_t nh = stepsFor(params.search_deg, 1.0);
  const int32_t min_common = std::max(params.min_overlap_cells / 2, at_apriori.n / 4);
  const int32_t min_grid = std::max(8, min_common / kStride);
  double best = std::numeric_limits<double>::infinity();
  int32_t bi = nxy, bj = nxy, bk = nh;
  for (int32_t k = 0; k <= 2 * nh; ++k) {
    for (int32_t j = 0; j <= 2 * nxy; ++j) {
      for (int32_t i = 0; i <= 2 * nxy; ++i) {
        const Moments m =
            moments(a, shiftedPose(apriori, (i - nxy) * cell, (j - nxy) * cell, (k - nh) * kDegToRad),
                    params.max_range_m, kStride);
        double v = std::numeric_limits<double>::infinity();
        if (m.n >= min_grid) v = std::max(0.0, m.sum2 / m.n - (m.sum / m.n) * (m.sum / m.n));
        cost_[k][j][i] = v;
        if (v < best) {
          best = v;
          bi = i;
          bj = j;
          bk = k;
        }
      }
    }
  }
  if (!std::isfinite(best)) return out;
  // The second minimum: the lowest local minimum away from the best.
  double second = std::numeric_limits<double>::infinity();
  for (int32_t k = 0; k <= 2 * nh; ++k) {
    for (int32_t j = 0; j <= 2 * nxy; ++j) {
      for (int32_t i = 0; i <= 2 * nxy; ++i) {
        const double v = cost_[k][j][i];
        if (!std::isfinite(v) || v >= second) continue;
        if (std::hypot((i - bi) * cell, (j - bj) * cell) < params.second_min_distance_m &&
            std::abs(k - bk) < params.second_min_deg) {
          continue;
        }
        bool minimum = true;
        for (int32_t dk = -1; dk <= 1 && minimum; ++dk) {
          for (int32_t dj = -1; dj <= 1 && minimum; ++dj) {
            for (int32_t di = -1; di <= 1 && minimum; ++di) {
              const int32_t ii = i + di, jj = j + dj, kk = k + dk;
              if (ii < 0 || jj < 0 || kk < 0 || ii > 2 * nxy || jj > 2 * nxy || kk > 2 * nh) continue;
              if (cost_[kk][jj][ii] < v) minimum = false;
            }
          }
        }
        if (minimum) second = v;
      }
    }
  }
  // Equal minima (flat ground: every cost 0) are as ambiguous as they come.
  out.cost_ratio = !std::isfinite(second) ? 0.0 : (second > 0.0 ? best / second : 1.0);

  LevelledPose pose = shiftedPose(apriori, (bi - nxy) * cell, (bj - nxy) * cell, (bk - nh) * kDegToRad);
  const Moments start = moments(a, pose, params.max_range_m, 1);
  pose.translation_m.z() -= start.sum / std::max(1, start.n);  // d = e_a - z: moving B down by d zeroes it
  out.status = DemRegistrationStatus::kOk;
  if (!gaussNewton(a, params, min_common, pose, out)) {
    out.status = DemRegistrationStatus::kNotConverged;
    return out;
  }
  if (out.status != DemRegistrationStatus::kOk) return out;
  const double moved = (pose.translation_m - apriori.translation_m).head<2>().norm();
  if (out.cost_ratio > params.max_cost_ratio) {
    out.status = DemRegistrationStatus::kAmbiguous;
  } else if (moved > 1.5 * params.search_m) {
    out.status = DemRegistrationStatus::kNotConverged;
  } else {
    out.a_from_b = pose;
  }
  return out;
}

}  // namespace areomap
