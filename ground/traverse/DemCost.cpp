#include "ground/traverse/DemCost.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

#include <Eigen/Dense>

namespace areomap::traverse::demcost {

double sigmaAt(const std::optional<DemGrid>& sigma, double x, double y) {
  if (!sigma) return 0.0;
  const double s = demElevation(*sigma, x, y);
  return std::isfinite(s) ? s : std::numeric_limits<double>::infinity();
}

std::vector<Sample> samplesOf(const SiteProducts& b, const DemGrid& dem, double spacing_m,
                              const RegistrationParams& params) {
  const int stride = std::max(1, static_cast<int>(std::lround(spacing_m / dem.cell_m)));
  std::vector<Sample> out;
  for (int r = stride / 2; r < dem.rows; r += stride) {
    for (int c = stride / 2; c < dem.cols; c += stride) {
      const float v = dem.at(c, r);
      if (v == dem.nodata || !std::isfinite(v)) continue;
      const Eigen::Vector3d p(dem.northOfRow(r), dem.eastOfCol(c), -v);
      if (p.head<2>().norm() > params.max_range_m) continue;
      const double s = sigmaAt(b.dem_sigma, p.x(), p.y());
      if (s > params.max_sigma_m) continue;
      out.push_back({p, s * s});
    }
  }
  return out;
}

int minSamples(const SiteProducts& a, const SiteProducts& b, const RegistrationParams& params) {
  const double area_per_sample = std::pow(std::max(params.sample_spacing_m, b.dem.cell_m), 2);
  return std::max(20,
                  static_cast<int>(params.min_overlap_cells * a.dem.cell_m * a.dem.cell_m / area_per_sample));
}

double Moments::variance() const {
  return std::max(0.0, wdd / w - mean() * mean());
}

namespace {

// The plane d = c0 + c1 x + c2 y of the weighted least squares with the prior on c1, c2, and the weighted
// mean square of the differences about it.
Eigen::Vector3d planeOf(const Moments& m, double tilt_sigma_rad, double& mean_square) {
  Eigen::Matrix3d a;
  a << m.w, m.wx, m.wy, m.wx, m.wxx, m.wxy, m.wy, m.wxy, m.wyy;
  a /= m.w;
  const Eigen::Vector3d b = Eigen::Vector3d(m.wd, m.wxd, m.wyd) / m.w;
  // Minimise S(c) / V + n (c1^2 + c2^2) / sigma^2, S the weighted mean square about the plane.
  const double lambda = m.variance() / (std::max(1, m.n) * tilt_sigma_rad * tilt_sigma_rad);
  a(1, 1) += lambda;
  a(2, 2) += lambda;
  const Eigen::Vector3d c = a.ldlt().solve(b);
  a(1, 1) -= lambda;
  a(2, 2) -= lambda;
  mean_square = std::max(0.0, m.wdd / m.w - 2.0 * c.dot(b) + c.dot(a * c));
  return c;
}

}  // namespace

Eigen::Vector2d Moments::levellingTilt(double tilt_sigma_rad) const {
  if (!(tilt_sigma_rad > 0.0) || n < 3) return Eigen::Vector2d::Zero();
  double unused = 0.0;
  const Eigen::Vector3d c = planeOf(*this, tilt_sigma_rad, unused);
  // omega_x y - omega_y x cancels c1 x + c2 y: omega = (-c2, c1).
  return {-c.z(), c.y()};
}

double Moments::levelledVariance(double tilt_sigma_rad) const {
  if (!(tilt_sigma_rad > 0.0) || n < 3) return variance();
  double mean_square = 0.0;
  (void)planeOf(*this, tilt_sigma_rad, mean_square);
  return mean_square;
}

Moments moments(const SiteProducts& a, const DemGrid& dem_a, const std::vector<Sample>& samples,
                const RelativePose& pose, const RegistrationParams& params) {
  Moments m;
  const Eigen::Matrix3d r = pose.rotation();
  for (const Sample& s : samples) {
    const Eigen::Vector3d p = r * s.b_m + pose.translation_m;
    if (p.head<2>().squaredNorm() > params.max_range_m * params.max_range_m) continue;
    const double e = demElevation(dem_a, p.x(), p.y());
    if (!std::isfinite(e)) continue;
    const double sa = sigmaAt(a.dem_sigma, p.x(), p.y());
    if (sa > params.max_sigma_m) continue;
    const double w = 1.0 / (kFloorSigmaM * kFloorSigmaM + sa * sa + s.sigma2);
    const double d = e + p.z();
    m.w += w;
    m.wd += w * d;
    m.wdd += w * d * d;
    m.dd += d * d;
    m.ss += sa * sa + s.sigma2;
    ++m.n;
    if (!(params.tilt_sigma_rad > 0.0)) continue;  // the plane's moments are read only when it is solved
    m.wx += w * p.x();
    m.wy += w * p.y();
    m.wxx += w * p.x() * p.x();
    m.wxy += w * p.x() * p.y();
    m.wyy += w * p.y() * p.y();
    m.wxd += w * p.x() * d;
    m.wyd += w * p.y() * d;
  }
  return m;
}

double designEffect(const SiteProducts& a, const std::vector<Sample>& samples, const RelativePose& pose,
                    const RegistrationParams& params, double rms_m) {
  struct Residual {
    double x, y, d;
  };
  std::vector<Residual> res;
  const Eigen::Matrix3d r = pose.rotation();
  double sum = 0.0, sum2 = 0.0;
  for (const Sample& s : samples) {
    const Eigen::Vector3d p = r * s.b_m + pose.translation_m;
    if (p.head<2>().squaredNorm() > params.max_range_m * params.max_range_m) continue;
    const double e = demElevation(a.dem, p.x(), p.y());
    if (!std::isfinite(e) || sigmaAt(a.dem_sigma, p.x(), p.y()) > params.max_sigma_m) continue;
    const double d = e + p.z();
    if (std::fabs(d) > 3.0 * rms_m) continue;
    res.push_back({p.x(), p.y(), d});
    sum += d;
    sum2 += d * d;
  }
  if (res.size() < 100) return 1.0;
  const double n = static_cast<double>(res.size());
  const double mean = sum / n, var = std::max(sum2 / n - mean * mean, 1e-12);
  double factor = 1.0;
  for (double side = 4.0 * params.sample_spacing_m; side < params.max_range_m; side *= 2.0) {
    std::map<std::pair<long, long>, std::pair<double, int>> blocks;
    for (const Residual& q : res) {
      auto& b = blocks[{std::lround(std::floor(q.x / side)), std::lround(std::floor(q.y / side))}];
      b.first += q.d;
      ++b.second;
    }
    // Blocks at least half full, as in the interior of the overlap.
    int full = 0, per_block_max = 0;
    for (const auto& [key, b] : blocks) per_block_max = std::max(per_block_max, b.second);
    double m1 = 0.0, m2 = 0.0, count = 0.0;
    for (const auto& [key, b] : blocks) {
      if (2 * b.second < per_block_max) continue;
      const double bm = b.first / b.second - mean;
      m1 += b.second;
      m2 += bm * bm;
      count += 1.0;
      ++full;
    }
    if (full < 8) break;
    const double per_block = m1 / count;
    factor = std::max(factor, (m2 / count) * per_block / var);
  }
  return factor;
}

}  // namespace areomap::traverse::demcost
