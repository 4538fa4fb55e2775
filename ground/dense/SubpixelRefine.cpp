#include "ground/dense/SubpixelRefine.hpp"

#include <atomic>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

namespace areomap::dense {

namespace {

constexpr int kUnknowns = 5;  // d, gx, gy, a, b
using Normal = Eigen::Matrix<double, kUnknowns, kUnknowns>;
using Vector = Eigen::Matrix<double, kUnknowns, 1>;

// Cubic convolution (Keys, a = -1/2) of one row at xr, with its derivative; false outside the row's
// interpolable part (one pixel of support on the left, two on the right).
inline bool sampleRow(const float* row, int cols, double xr, double& value, double& slope) {
  const int x0 = static_cast<int>(std::floor(xr));
  if (x0 < 1 || x0 + 2 >= cols) return false;
  const double f = xr - x0;
  const double p0 = row[x0 - 1], p1 = row[x0], p2 = row[x0 + 1], p3 = row[x0 + 2];
  const double c1 = 0.5 * (p2 - p0);
  const double c2 = p0 - 2.5 * p1 + 2.0 * p2 - 0.5 * p3;
  const double c3 = 0.5 * (p3 - p0) + 1.5 * (p1 - p2);
  value = p1 + f * (c1 + f * (c2 + f * c3));
  slope = c1 + f * (2.0 * c2 + 3.0 * f * c3);
  return true;
}

struct Fit {
  double d = 0.0, sigma = 0.0;
};

// Gauss-Newton for one pixel; false when the fit fails (see SubpixelStats::kept).
bool fitPixel(const cv::Mat& lf, const cv::Mat& rf, int x, int y, double d0, const SubpixelOptions& o,
              Fit& fit) {
  const int hw = o.half_width, hh = o.half_height;
  if (x - hw < 0 || x + hw >= lf.cols || y - hh < 0 || y + hh >= lf.rows) return false;
  double d = d0, gx = 0.0, gy = 0.0, a = 0.0, b = 1.0;
  const int samples = (2 * hw + 1) * (2 * hh + 1);
  for (int it = 0; it < o.max_iterations; ++it) {
    // The normal equations' sums, written out: the Jacobian row is (g, g i, g j, 1, R).
    double gg = 0, ggi = 0, ggj = 0, ggii = 0, ggij = 0, ggjj = 0, sg = 0, sgi = 0, sgj = 0;
    double sgr = 0, sgri = 0, sgrj = 0, sr = 0, srr = 0;
    double ug = 0, ugi = 0, ugj = 0, ures = 0, ur = 0, rss = 0;
    for (int j = -hh; j <= hh; ++j) {
      const float* lrow = lf.ptr<float>(y + j);
      const float* rrow = rf.ptr<float>(y + j);
      const double xj = x - d - gy * j;
      double row_gg = 0, row_ggi = 0, row_ggii = 0, row_g = 0, row_gi = 0, row_gr = 0, row_gri = 0;
      double row_ug = 0, row_ugi = 0;
      for (int i = -hw; i <= hw; ++i) {
        double r_value = 0.0, r_slope = 0.0;
        if (!sampleRow(rrow, rf.cols, xj + i * (1.0 - gx), r_value, r_slope)) return false;
        const double res = lrow[x + i] - (a + b * r_value);
        const double g = -b * r_slope;  // d(model) / d(d)
        const double g2 = g * g;
        row_gg += g2;
        row_ggi += g2 * i;
        row_ggii += g2 * i * i;
        row_g += g;
        row_gi += g * i;
        row_gr += g * r_value;
        row_gri += g * r_value * i;
        row_ug += g * res;
        row_ugi += g * res * i;
        sr += r_value;
        srr += r_value * r_value;
        ures += res;
        ur += r_value * res;
        rss += res * res;
      }
      gg += row_gg;
      ggi += row_ggi;
      ggii += row_ggii;
      ggj += row_gg * j;
      ggij += row_ggi * j;
      ggjj += row_gg * j * j;
      sg += row_g;
      sgi += row_gi;
      sgj += row_g * j;
      sgr += row_gr;
      sgri += row_gri;
      sgrj += row_gr * j;
      ug += row_ug;
      ugi += row_ugi;
      ugj += row_ug * j;
    }
    Normal n;
    n << gg, ggi, ggj, sg, sgr,      //
        ggi, ggii, ggij, sgi, sgri,  //
        ggj, ggij, ggjj, sgj, sgrj,  //
        sg, sgi, sgj, samples, sr,   //
        sgr, sgri, sgrj, sr, srr;
    const Vector u(ug, ugi, ugj, ures, ur);
    const Eigen::LDLT<Normal> ldlt(n);
    if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0.0)) return false;
    const Vector step = ldlt.solve(u);
    if (!step.allFinite()) return false;
    d += step(0);
    gx += step(1);
    gy += step(2);
    a += step(3);
    b += step(4);
    if (!(std::fabs(d - d0) <= o.max_shift_px) || !(b >= o.min_gain && b <= o.max_gain)) return false;
    if (std::fabs(step(0)) < o.converged_px) {
      const double var_d = ldlt.solve(Vector::Unit(0))(0);
      fit.d = d;
      fit.sigma = std::sqrt(std::max(0.0, rss / (samples - kUnknowns) * var_d));
      return true;
    }
  }
  return false;
}

}  // namespace

SubpixelStats refineSubpixel(const cv::Mat& left, const cv::Mat& right, cv::Mat& disparity,
                             const cv::Mat& valid, const SubpixelOptions& options, cv::Mat* sigma_px) {
  cv::Mat lf, rf;
  left.convertTo(lf, CV_32F);
  right.convertTo(rf, CV_32F);
  if (sigma_px != nullptr) {
    *sigma_px = cv::Mat(disparity.size(), CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  }
  std::atomic<long long> refined{0}, kept{0};
  cv::parallel_for_(cv::Range(0, disparity.rows), [&](const cv::Range& range) {
    long long ok = 0, bad = 0;
    for (int y = range.start; y < range.end; ++y) {
      float* drow = disparity.ptr<float>(y);
      const uint8_t* vrow = valid.ptr<uint8_t>(y);
      float* srow = sigma_px != nullptr ? sigma_px->ptr<float>(y) : nullptr;
      for (int x = 0; x < disparity.cols; ++x) {
        if (!vrow[x]) continue;
        Fit fit;
        if (fitPixel(lf, rf, x, y, drow[x], options, fit)) {
          drow[x] = static_cast<float>(fit.d);
          if (srow != nullptr) srow[x] = static_cast<float>(fit.sigma);
          ++ok;
        } else {
          ++bad;  // the matcher's (parabola) disparity stays
        }
      }
    }
    refined += ok;
    kept += bad;
  });
  SubpixelStats s;
  s.refined = refined.load();
  s.kept = kept.load();
  return s;
}

}  // namespace areomap::dense
