#include "ground/dense/ParallaxCurve.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace areomap::dense {

namespace {
constexpr int kFitRounds = 5;         // rejection rounds of the robust fit
constexpr double kRejectSigmas = 3.0;
constexpr double kMinSigmaPx = 0.5;   // floor of the residual scale (integer tie disparities)
}  // namespace

ParallaxCurve fitParallaxCurve(const std::vector<TieDisparity>& ties, int rows) {
  ParallaxCurve curve;
  if (ties.empty() || rows <= 0) return curve;
  std::vector<bool> use(ties.size(), true);
  for (int round = 0; round < kFitRounds; ++round) {
    const int n = static_cast<int>(std::count(use.begin(), use.end(), true));
    const int order = n >= 6 ? 3 : (n >= 3 ? 2 : 1);  // coefficients
    Eigen::MatrixXd a(n, order);
    Eigen::VectorXd b(n);
    int i = 0;
    for (std::size_t k = 0; k < ties.size(); ++k) {
      if (!use[k]) continue;
      const double t = ties[k].y_px / rows;
      a(i, 0) = 1.0;
      if (order > 1) a(i, 1) = t;
      if (order > 2) a(i, 2) = t * t;
      b(i) = ties[k].disparity_px;
      ++i;
    }
    const Eigen::VectorXd c = a.colPivHouseholderQr().solve(b);
    curve.c0 = c(0);
    curve.c1 = order > 1 ? c(1) : 0.0;
    curve.c2 = order > 2 ? c(2) : 0.0;
    double ss = 0.0;
    for (std::size_t k = 0; k < ties.size(); ++k) {
      if (!use[k]) continue;
      const double r = ties[k].disparity_px - curve.at(ties[k].y_px, rows);
      ss += r * r;
    }
    curve.inliers = n;
    curve.sigma_px = std::sqrt(ss / std::max(1, n));
    const double limit = kRejectSigmas * std::max(curve.sigma_px, kMinSigmaPx);
    bool changed = false;
    for (std::size_t k = 0; k < ties.size(); ++k) {
      const bool inside = std::abs(ties[k].disparity_px - curve.at(ties[k].y_px, rows)) <= limit;
      // Keep at least three ties in the fit.
      if (use[k] != inside && (inside || n > 3)) {
        use[k] = inside;
        changed = true;
      }
    }
    if (!changed) break;
  }
  return curve;
}

std::vector<RowRange> parallaxRowRanges(const std::vector<TieDisparity>& ties, int rows, int min_px,
                                        int max_px, int margin_px, int window_rows) {
  std::vector<RowRange> out(static_cast<std::size_t>(std::max(rows, 0)), RowRange{min_px, max_px});
  if (ties.empty() || rows <= 0) return out;
  const ParallaxCurve curve = fitParallaxCurve(ties, rows);
  // Residuals are not rejected here: a real tie far from the curve (a rock in front) widens its rows.
  double global = kRejectSigmas * std::max(curve.sigma_px, kMinSigmaPx);
  std::vector<double> below(out.size(), 0.0), above(out.size(), 0.0);
  std::vector<bool> seen(out.size(), false);
  for (const TieDisparity& t : ties) {
    const double r = t.disparity_px - curve.at(t.y_px, rows);
    global = std::max(global, std::abs(r));
    const int y0 = std::max(0, static_cast<int>(std::floor(t.y_px)) - window_rows);
    const int y1 = std::min(rows - 1, static_cast<int>(std::ceil(t.y_px)) + window_rows);
    for (int y = y0; y <= y1; ++y) {
      below[static_cast<std::size_t>(y)] = std::max(below[static_cast<std::size_t>(y)], -r);
      above[static_cast<std::size_t>(y)] = std::max(above[static_cast<std::size_t>(y)], r);
      seen[static_cast<std::size_t>(y)] = true;
    }
  }
  const double floor_px = kRejectSigmas * std::max(curve.sigma_px, kMinSigmaPx);
  for (int y = 0; y < rows; ++y) {
    const std::size_t i = static_cast<std::size_t>(y);
    const double centre = curve.at(y, rows);
    const double lo_w = seen[i] ? std::max(below[i], floor_px) : global;
    const double hi_w = seen[i] ? std::max(above[i], floor_px) : global;
    int lo = static_cast<int>(std::floor(centre - lo_w)) - margin_px;
    int hi = static_cast<int>(std::ceil(centre + hi_w)) + margin_px;
    lo = std::clamp(lo, min_px, max_px);
    hi = std::clamp(hi, lo, max_px);
    out[i] = RowRange{lo, hi};
  }
  return out;
}

}  // namespace areomap::dense
