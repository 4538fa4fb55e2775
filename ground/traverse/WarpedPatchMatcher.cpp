#include "ground/traverse/WarpedPatchMatcher.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace areomap::traverse {

namespace {

// The pyramid level whose pixel best matches a grid step of `scale` full-resolution pixels.
int levelFor(const std::vector<cv::Mat>& pyramid, double scale) {
  const int l = static_cast<int>(std::floor(std::log2(std::max(scale, 1.0)) + 0.5));
  return std::clamp(l, 0, static_cast<int>(pyramid.size()) - 1);
}

double nccOf(const std::vector<double>& t, const std::vector<double>& s) {
  const double n = static_cast<double>(t.size());
  double st = 0, ss = 0, stt = 0, sss = 0, sts = 0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    st += t[k];
    ss += s[k];
    stt += t[k] * t[k];
    sss += s[k] * s[k];
    sts += t[k] * s[k];
  }
  const double vt = n * stt - st * st, vs = n * sss - ss * ss;
  if (vt <= 1e-9 || vs <= 1e-9) return -2.0;
  return (n * sts - st * ss) / std::sqrt(vt * vs);
}

}  // namespace

double samplePyramid(const std::vector<cv::Mat>& pyramid, int level, double x_px, double y_px) {
  const cv::Mat& m = pyramid[level];
  const double f = 1.0 / (1 << level);
  const double x = x_px * f, y = y_px * f;
  if (!(x >= 0.0 && y >= 0.0)) return NAN;
  const int c = static_cast<int>(x), r = static_cast<int>(y);
  if (c + 1 >= m.cols || r + 1 >= m.rows) return NAN;
  const double fx = x - c, fy = y - r;
  const float* row0 = m.ptr<float>(r);
  const float* row1 = m.ptr<float>(r + 1);
  return row0[c] * (1 - fx) * (1 - fy) + row0[c + 1] * fx * (1 - fy) + row1[c] * (1 - fx) * fy +
         row1[c + 1] * fx * fy;
}

PatchMatch matchWarpedPatch(const std::vector<cv::Mat>& image_i, const Eigen::Vector2d& i_px,
                            const std::vector<cv::Mat>& image_j, const Eigen::Vector2d& j_predicted_px,
                            const Eigen::Matrix2d& a, const PatchParams& params) {
  PatchMatch out;
  const double det = a.determinant();
  if (!std::isfinite(det) || std::fabs(det) < 1e-6) return out;
  // Grid step maps: I offset = mi * g, J offset = mj * g; the coarser image steps one of its pixels.
  Eigen::Matrix2d mi = Eigen::Matrix2d::Identity(), mj = a;
  if (std::fabs(det) < 1.0) {
    mi = a.inverse();
    mj = Eigen::Matrix2d::Identity();
  }
  const int level_i = levelFor(image_i, std::sqrt(std::fabs(mi.determinant())));
  const int level_j = levelFor(image_j, std::sqrt(std::fabs(mj.determinant())));
  const int h = params.half;
  const int radius =
      std::max(2, static_cast<int>(std::ceil(params.radius_px / std::sqrt(std::fabs(mj.determinant())))));
  const int side = 2 * h + 1;

  std::vector<double> tmpl(static_cast<std::size_t>(side) * side);
  for (int v = -h; v <= h; ++v) {
    for (int u = -h; u <= h; ++u) {
      const Eigen::Vector2d p = i_px + mi * Eigen::Vector2d(u, v);
      const double value = samplePyramid(image_i, level_i, p.x(), p.y());
      if (!std::isfinite(value)) return out;
      tmpl[static_cast<std::size_t>(v + h) * side + (u + h)] = value;
    }
  }
  const int wide = 2 * (h + radius) + 1;
  std::vector<double> search(static_cast<std::size_t>(wide) * wide);
  for (int v = -h - radius; v <= h + radius; ++v) {
    for (int u = -h - radius; u <= h + radius; ++u) {
      const Eigen::Vector2d p = j_predicted_px + mj * Eigen::Vector2d(u, v);
      const double value = samplePyramid(image_j, level_j, p.x(), p.y());
      if (!std::isfinite(value)) return out;
      search[static_cast<std::size_t>(v + h + radius) * wide + (u + h + radius)] = value;
    }
  }
  const int ns = 2 * radius + 1;
  std::vector<double> score(static_cast<std::size_t>(ns) * ns, -2.0);
  std::vector<double> window(tmpl.size());
  int best_k = -1;
  for (int sy = 0; sy < ns; ++sy) {
    for (int sx = 0; sx < ns; ++sx) {
      for (int v = 0; v < side; ++v) {
        for (int u = 0; u < side; ++u) {
          window[static_cast<std::size_t>(v) * side + u] =
              search[static_cast<std::size_t>(v + sy) * wide + (u + sx)];
        }
      }
      const int k = sy * ns + sx;
      score[k] = nccOf(tmpl, window);
      if (best_k < 0 || score[k] > score[best_k]) best_k = k;
    }
  }
  out.ncc = score[best_k];
  if (out.ncc <= -1.5) {
    out.result = PatchResult::kFlat;
    return out;
  }
  const int bx = best_k % ns, by = best_k / ns;
  // Second peak: the best local maximum at least 2 steps from the best.
  for (int sy = 0; sy < ns; ++sy) {
    for (int sx = 0; sx < ns; ++sx) {
      if (std::max(std::abs(sx - bx), std::abs(sy - by)) < 2) continue;
      const double c = score[sy * ns + sx];
      bool peak = true;
      for (int dy = -1; dy <= 1 && peak; ++dy) {
        for (int dx = -1; dx <= 1 && peak; ++dx) {
          const int x = sx + dx, y = sy + dy;
          if ((dx == 0 && dy == 0) || x < 0 || y < 0 || x >= ns || y >= ns) continue;
          if (score[y * ns + x] > c) peak = false;
        }
      }
      if (peak) out.second = std::max(out.second, c);
    }
  }
  if (out.ncc < params.min_ncc) {
    out.result = PatchResult::kLowNcc;
    return out;
  }
  if (out.second > params.max_second_ratio * out.ncc) {
    out.result = PatchResult::kAmbiguous;
    return out;
  }
  if (bx == 0 || by == 0 || bx == ns - 1 || by == ns - 1) {
    out.result = PatchResult::kEdgePeak;
    return out;
  }
  // Least squares from the integer peak: translation d (grid steps) with gain and offset, template
  // normalised; the search image resampled at each step.
  Eigen::Vector2d d(bx - radius, by - radius);
  double tm = 0, tv = 0;
  for (double t : tmpl) tm += t;
  tm /= static_cast<double>(tmpl.size());
  for (double t : tmpl) tv += (t - tm) * (t - tm);
  const double tn = std::sqrt(tv);
  std::vector<double> sv(tmpl.size()), gx(tmpl.size()), gy(tmpl.size());
  const Eigen::Vector2d start = d;
  for (int it = 0; it < params.lsm_iterations; ++it) {
    for (int v = -h; v <= h; ++v) {
      for (int u = -h; u <= h; ++u) {
        const std::size_t k = static_cast<std::size_t>(v + h) * side + (u + h);
        const Eigen::Vector2d g = d + Eigen::Vector2d(u, v);
        const Eigen::Vector2d p = j_predicted_px + mj * g;
        const Eigen::Vector2d ex = mj * Eigen::Vector2d(0.5, 0.0), ey = mj * Eigen::Vector2d(0.0, 0.5);
        sv[k] = samplePyramid(image_j, level_j, p.x(), p.y());
        gx[k] = samplePyramid(image_j, level_j, p.x() + ex.x(), p.y() + ex.y()) -
                samplePyramid(image_j, level_j, p.x() - ex.x(), p.y() - ex.y());
        gy[k] = samplePyramid(image_j, level_j, p.x() + ey.x(), p.y() + ey.y()) -
                samplePyramid(image_j, level_j, p.x() - ey.x(), p.y() - ey.y());
        if (!std::isfinite(sv[k]) || !std::isfinite(gx[k]) || !std::isfinite(gy[k])) {
          out.result = PatchResult::kOutside;
          return out;
        }
      }
    }
    double sm = 0, svv = 0;
    for (double s : sv) sm += s;
    sm /= static_cast<double>(sv.size());
    for (double s : sv) svv += (s - sm) * (s - sm);
    const double sn = std::sqrt(std::max(svv, 1e-12));
    // r = tn_k - sn_k(d); d(sn_k)/dd = grad / sn (the normalisation's own derivative is second order).
    Eigen::Matrix2d n = Eigen::Matrix2d::Zero();
    Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
    for (std::size_t k = 0; k < sv.size(); ++k) {
      const double r = (tmpl[k] - tm) / tn - (sv[k] - sm) / sn;
      const Eigen::Vector2d j(gx[k] / sn, gy[k] / sn);
      n.noalias() += j * j.transpose();
      rhs += j * r;
    }
    const Eigen::Vector2d step = n.ldlt().solve(rhs);
    if (!step.allFinite()) break;
    d += step.cwiseMax(-0.5).cwiseMin(0.5);
    if ((d - start).cwiseAbs().maxCoeff() > 1.0) {
      out.result = PatchResult::kLsmDiverged;
      return out;
    }
    if (step.norm() < 1e-3) break;
  }
  // NCC at the refined position.
  for (int v = -h; v <= h; ++v) {
    for (int u = -h; u <= h; ++u) {
      const Eigen::Vector2d p = j_predicted_px + mj * (d + Eigen::Vector2d(u, v));
      window[static_cast<std::size_t>(v + h) * side + (u + h)] =
          samplePyramid(image_j, level_j, p.x(), p.y());
    }
  }
  out.ncc_final = nccOf(tmpl, window);
  out.j_px = j_predicted_px + mj * d;
  out.result = PatchResult::kOk;
  return out;
}

}  // namespace areomap::traverse
