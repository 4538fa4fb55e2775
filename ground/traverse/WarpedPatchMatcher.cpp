#include "ground/traverse/WarpedPatchMatcher.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include <Eigen/Dense>

#include "firmware_core/match/Ncc.hpp"
#include "ground/traverse/PatchWarp.hpp"

namespace areomap::traverse {

namespace {

// The largest correction of the warp's linear part (per element) that the least-squares step may make.
constexpr double kMaxAffineFix = 0.3;
// The score of a shift whose window leaves the image (below any NCC and the flat window's -2).
constexpr double kUnscored = -3.0;

// The pyramid level whose pixel best matches a grid step of `scale` full-resolution pixels.
int levelFor(const std::vector<cv::Mat>& pyramid, double scale) {
  const int l = static_cast<int>(std::floor(std::log2(std::max(scale, 1.0)) + 0.5));
  return std::clamp(l, 0, static_cast<int>(pyramid.size()) - 1);
}

// A bilinear sample of an image at a point (its pixel and the weights of its fraction), also moved by whole
// pixels: the search steps a window by whole pixels with the weights kept. NaN outside the image.
struct BilinearTap {
  int c = 0, r = 0;
  double fx = 0.0, fy = 0.0;
  BilinearTap() = default;
  explicit BilinearTap(const Eigen::Vector2d& p)
      : c(static_cast<int>(std::floor(p.x()))), r(static_cast<int>(std::floor(p.y()))) {
    fx = p.x() - c;
    fy = p.y() - r;
  }
  double at(const cv::Mat& m, int dx, int dy) const {
    const int cc = c + dx, rr = r + dy;
    if (cc < 0 || rr < 0 || cc + 1 >= m.cols || rr + 1 >= m.rows) return NAN;
    return inside(m, dx, dy);
  }
  // at() where the caller knows the moved pixel and its neighbours are in the image.
  double inside(const cv::Mat& m, int dx, int dy) const {
    const int cc = c + dx, rr = r + dy;
    const float* row0 = m.ptr<float>(rr);
    const float* row1 = m.ptr<float>(rr + 1);
    return row0[cc] * (1 - fx) * (1 - fy) + row0[cc + 1] * fx * (1 - fy) + row1[cc] * (1 - fx) * fy +
           row1[cc + 1] * fx * fy;
  }
};

// Bilinear sample of a pyramid level whose pixel is 1 / f full-resolution pixels, at full-resolution pixel
// coordinates (NaN outside): samplePyramid's arithmetic, with the level's image and scale found once.
inline double sampleLevel(const cv::Mat& m, double f, double x_px, double y_px) {
  const double x = x_px * f, y = y_px * f;
  if (!(x >= 0.0 && y >= 0.0)) return NAN;
  return BilinearTap(Eigen::Vector2d(x, y)).at(m, 0, 0);
}

// Most taps of a footprint along its long axis (a grid step up to this many pyramid pixels long).
constexpr int kMaxFootprintTaps = 16;

// Samples an image through a grid-step map m (grid step -> full-resolution pixels) low-passed to the
// step's footprint, which is anisotropic where the views see the ground at different obliquities: the
// pyramid level of the footprint's short axis (singular value), and along its long axis the mean of taps
// one level pixel apart spanning the step (a box over the footprint). With an isotropic map this is the
// pyramid level of its scale alone.
struct Footprint {
  const std::vector<cv::Mat>* pyramid = nullptr;
  int level = 0;
  const cv::Mat* image = nullptr;                  // pyramid[level]
  double f = 1.0;                                  // its pixels per full-resolution pixel
  Eigen::Vector2d axis = Eigen::Vector2d::Zero();  // the long axis' extent (full-resolution pixels)
  int taps = 1;

  Footprint(const std::vector<cv::Mat>& p, const Eigen::Matrix2d& m) : pyramid(&p) {
    const Eigen::JacobiSVD<Eigen::Matrix2d> svd(m, Eigen::ComputeFullU);
    const double s_long = svd.singularValues()[0], s_short = svd.singularValues()[1];
    level = levelFor(p, s_short);
    const double pixel = static_cast<double>(1 << level);
    taps = std::clamp(static_cast<int>(std::lround(s_long / pixel)), 1, kMaxFootprintTaps);
    if (taps > 1) axis = svd.matrixU().col(0) * s_long;
    image = &p[static_cast<std::size_t>(level)];
    f = 1.0 / (1 << level);
  }

  double at(double x_px, double y_px) const {
    if (taps == 1) return sampleLevel(*image, f, x_px, y_px);
    double sum = 0.0;
    for (int t = 0; t < taps; ++t) {
      const double along = (t + 0.5) / taps - 0.5;
      sum += sampleLevel(*image, f, x_px + along * axis.x(), y_px + along * axis.y());
    }
    return sum / taps;  // NaN when a tap is
  }
};

// A window that varies less than this (n * sum_sq - sum^2) has no NCC.
constexpr double kMinVariance = 1e-9;

double nccOf(const std::vector<double>& t, const std::vector<double>& s) {
  return nccOfSamples(t.data(), s.data(), static_cast<int32_t>(t.size()), kMinVariance);
}

// The template's sums, made once for a search, and a window's NCC from its own sums: nccOf's (the same sums
// in the same order).
struct TemplateSums {
  double n = 0.0, sum = 0.0, sq = 0.0;
  explicit TemplateSums(const std::vector<double>& t) : n(static_cast<double>(t.size())) {
    for (double v : t) {
      sum += v;
      sq += v * v;
    }
  }
  double ncc(double ss, double sss, double sts) const {
    const double var_t = n * sq - sum * sum;
    return var_t <= kMinVariance
               ? kNccInvalid
               : nccFromSums(n, sum, var_t, ss, sss, sts, std::nextafter(kMinVariance, INFINITY));
  }
};

// The search's windows where J is stepped by whole pixels at full resolution: each template sample's tap
// is made once, the window's bounds are checked once per shift, and the template's sums once; a window's
// score is nccOf's (the same sums in the same order).
struct WholePixelWindows {
  const cv::Mat& image;
  const std::vector<double>& tmpl;
  std::vector<BilinearTap> taps;
  int min_c = 0, max_c = 0, min_r = 0, max_r = 0;  // the taps' pixels
  TemplateSums sums;

  WholePixelWindows(const cv::Mat& j, const Eigen::Vector2d& j_predicted_px,
                    const std::vector<Eigen::Vector2d>& off_j, const std::vector<double>& t)
      : image(j), tmpl(t), taps(off_j.size()), sums(t) {
    for (std::size_t k = 0; k < off_j.size(); ++k) {
      taps[k] = BilinearTap(j_predicted_px + off_j[k]);
      min_c = k == 0 ? taps[k].c : std::min(min_c, taps[k].c);
      max_c = k == 0 ? taps[k].c : std::max(max_c, taps[k].c);
      min_r = k == 0 ? taps[k].r : std::min(min_r, taps[k].r);
      max_r = k == 0 ? taps[k].r : std::max(max_r, taps[k].r);
    }
  }

  // False when the window at shift (dx, dy) leaves the image; else its NCC in `score`.
  bool score(int dx, int dy, double& score) const {
    if (min_c + dx < 0 || min_r + dy < 0 || max_c + dx + 1 >= image.cols || max_r + dy + 1 >= image.rows)
      return false;
    double ss = 0.0, sss = 0.0, sts = 0.0;
    for (std::size_t k = 0; k < taps.size(); ++k) {
      const double v = taps[k].inside(image, dx, dy);  // the window's bounds are checked above
      ss += v;
      sss += v * v;
      sts += tmpl[k] * v;
    }
    score = sums.ncc(ss, sss, sts);
    return true;
  }
};

// The footprint's low-pass on its level's pixel lattice over a box: each node the mean of the footprint's
// taps about it, so that a sample through the footprint is one bilinear interpolation of the nodes instead
// of one per tap (the box along the long axis taken before the interpolation instead of after it: the same
// low-pass but for the interpolation's own smoothing, and the same values where there is one tap). NaN
// where a tap leaves the image. Its nodes are kept from call to call (a search's buffer per thread).
class FootprintGrid {
 public:
  // The nodes that the full-resolution box [lo, hi] reads.
  void cover(const Footprint& fp, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
    f_ = fp.f;
    // A node of margin on every side: a position computed as the box's bound may round across it.
    x0_ = static_cast<int>(std::floor(lo.x() * f_)) - 1;
    y0_ = static_cast<int>(std::floor(lo.y() * f_)) - 1;
    cols_ = static_cast<int>(std::floor(hi.x() * f_)) - x0_ + 3;
    rows_ = static_cast<int>(std::floor(hi.y() * f_)) - y0_ + 3;
    nodes_.resize(static_cast<std::size_t>(cols_) * rows_);
    const cv::Mat& m = *fp.image;
    for (int r = 0; r < rows_; ++r) {
      double* row = &nodes_[static_cast<std::size_t>(r) * cols_];
      for (int c = 0; c < cols_; ++c) {
        const double x = x0_ + c, y = y0_ + r;
        if (fp.taps == 1) {
          const int cc = x0_ + c, rr = y0_ + r;
          row[c] = cc < 0 || rr < 0 || cc >= m.cols || rr >= m.rows ? NAN : m.ptr<float>(rr)[cc];
          continue;
        }
        // The node in full-resolution pixels; f_ is a power of two, so the taps land on the same level
        // coordinates, bit for bit, as they would from the node itself.
        row[c] = fp.at(x / f_, y / f_);
      }
    }
  }
  // Level pixel coordinates of a full-resolution point, from the box's first node.
  Eigen::Vector2d local(const Eigen::Vector2d& p_px) const {
    return Eigen::Vector2d(p_px.x() * f_ - x0_, p_px.y() * f_ - y0_);
  }
  // The bilinear interpolation at local coordinates within the box (NaN where a node is).
  double at(double x, double y) const {
    const int c = static_cast<int>(x), r = static_cast<int>(y);
    const double fx = x - c, fy = y - r;
    const double* row0 = &nodes_[static_cast<std::size_t>(r) * cols_ + c];
    const double* row1 = row0 + cols_;
    return row0[0] * (1 - fx) * (1 - fy) + row0[1] * fx * (1 - fy) + row1[0] * (1 - fx) * fy + row1[1] * fx * fy;
  }
  double f() const { return f_; }

 private:
  std::vector<double> nodes_;
  int x0_ = 0, y0_ = 0, cols_ = 0, rows_ = 0;
  double f_ = 1.0;
};

// The search's windows where J is stepped by the grid map mj (J the finer view, sampled through its
// footprint). Where the search's box has fewer of the footprint level's pixels than half the samples the
// search reads, the footprint's low-pass is made once over it (FootprintGrid) and each sample is one
// bilinear interpolation of that; else (a footprint much longer than wide, or a wide search) each sample
// is taken through the footprint itself, as the least squares does. A window's score from the same sums
// as nccOf's.
struct GridWindows {
  const std::vector<double>& tmpl;
  const Footprint& footprint;
  const FootprintGrid* grid = nullptr;  // null: each sample through the footprint
  Eigen::Vector2d j_predicted_px;
  const Eigen::Matrix2d& mj;
  const std::vector<Eigen::Vector2d>& off_j;
  std::vector<Eigen::Vector2d> base;  // with the grid: each sample's local position at the zero shift
  Eigen::Vector2d step_x, step_y;     // and a grid step's move in local coordinates
  TemplateSums sums;

  GridWindows(FootprintGrid& g, const Footprint& fp, const Eigen::Vector2d& j_pred,
              const Eigen::Matrix2d& m, const std::vector<Eigen::Vector2d>& off, int radius,
              const std::vector<double>& t)
      : tmpl(t), footprint(fp), j_predicted_px(j_pred), mj(m), off_j(off), sums(t) {
    Eigen::Vector2d lo = j_predicted_px + off_j[0], hi = lo;
    for (const Eigen::Vector2d& o : off_j) {
      lo = lo.cwiseMin(j_predicted_px + o);
      hi = hi.cwiseMax(j_predicted_px + o);
    }
    const Eigen::Vector2d reach = mj.cwiseAbs() * Eigen::Vector2d(radius, radius);
    const Eigen::Vector2d box = (hi - lo + 2.0 * reach) * fp.f + Eigen::Vector2d(4.0, 4.0);
    const double samples = static_cast<double>(off_j.size()) * (2 * radius + 1) * (2 * radius + 1);
    if (box.x() * box.y() > 0.5 * samples) return;
    g.cover(fp, lo - reach, hi + reach);
    grid = &g;
    base.resize(off_j.size());
    for (std::size_t k = 0; k < off_j.size(); ++k) base[k] = g.local(j_predicted_px + off_j[k]);
    step_x = mj.col(0) * g.f();
    step_y = mj.col(1) * g.f();
  }

  // False when the window at shift (dx, dy) leaves the image; else its NCC in `score`.
  bool score(int dx, int dy, double& score) const {
    double ss = 0.0, sss = 0.0, sts = 0.0;
    if (grid != nullptr) {
      const Eigen::Vector2d shift = step_x * dx + step_y * dy;
      for (std::size_t k = 0; k < base.size(); ++k) {
        const double v = grid->at(base[k].x() + shift.x(), base[k].y() + shift.y());
        ss += v;
        sss += v * v;
        sts += tmpl[k] * v;
      }
    } else {
      const Eigen::Vector2d shift = j_predicted_px + mj * Eigen::Vector2d(dx, dy);
      for (std::size_t k = 0; k < off_j.size(); ++k) {
        const Eigen::Vector2d p = shift + off_j[k];
        const double v = footprint.at(p.x(), p.y());
        if (!std::isfinite(v)) return false;
        ss += v;
        sss += v * v;
        sts += tmpl[k] * v;
      }
    }
    if (!std::isfinite(ss)) return false;  // a sample's tap left the image
    score = sums.ncc(ss, sss, sts);
    return true;
  }
};

// The template on the grid: per grid sample k (row-major over the (2h+1)^2 grid) its value sampled in I and
// its offset in J from the prediction (through the surface where one is given, else the affine map mj).
// False when a template sample leaves I.
bool sampleTemplate(const Footprint& sample_i, const Eigen::Vector2d& i_px, const Eigen::Matrix2d& mi,
                    const Eigen::Matrix2d& mj, int h, const PatchSurface* surface, double tolerance_px,
                    std::vector<double>& tmpl, std::vector<Eigen::Vector2d>& off_j) {
  const int side = 2 * h + 1;
  for (int v = -h; v <= h; ++v) {
    for (int u = -h; u <= h; ++u) {
      const std::size_t k = static_cast<std::size_t>(v + h) * side + (u + h);
      const Eigen::Vector2d p = i_px + mi * Eigen::Vector2d(u, v);
      const double value = sample_i.at(p.x(), p.y());
      if (!std::isfinite(value)) return false;
      tmpl[k] = value;
    }
  }
  Eigen::Vector2d j_centre;
  if (surface != nullptr && surface->map(i_px, j_centre)) {
    surfaceOffsets(*surface, i_px, j_centre, mi, mj, h, tolerance_px, off_j);
    return true;
  }
  for (int v = -h; v <= h; ++v) {
    for (int u = -h; u <= h; ++u)
      off_j[static_cast<std::size_t>(v + h) * side + (u + h)] = mj * Eigen::Vector2d(u, v);
  }
  return true;
}

// The second peak: the best local maximum of the scores at least 2 steps from the best (bx, by); 0 when none.
double secondPeak(const std::vector<double>& score, int ns, int bx, int by) {
  double second = 0.0;
  for (int sy = 0; sy < ns; ++sy) {
    for (int sx = 0; sx < ns; ++sx) {
      if (std::max(std::abs(sx - bx), std::abs(sy - by)) < 2) continue;
      const double c = score[sy * ns + sx];
      if (c == kUnscored) continue;
      bool peak = true;
      for (int dy = -1; dy <= 1 && peak; ++dy) {
        for (int dx = -1; dx <= 1 && peak; ++dx) {
          const int x = sx + dx, y = sy + dy;
          if ((dx == 0 && dy == 0) || x < 0 || y < 0 || x >= ns || y >= ns) continue;
          if (score[y * ns + x] > c) peak = false;
        }
      }
      if (peak) second = std::max(second, c);
    }
  }
  return second;
}

// A peak on the search's edge, or beside a shift clipped by the image's edge, is not known to be one.
bool edgePeak(const std::vector<double>& score, int ns, int bx, int by) {
  bool clipped = false;
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      const int x = bx + dx, y = by + dy;
      if (x >= 0 && y >= 0 && x < ns && y < ns && score[y * ns + x] == kUnscored) clipped = true;
    }
  }
  return clipped || bx == 0 || by == 0 || bx == ns - 1 || by == ns - 1;
}

// The least squares stop once no unknown moves by this many of its own standard deviations.
constexpr double kSettledSigmas = 0.1;

// Least squares from the integer peak d (grid steps): translation d, with an affine correction B of the
// warp (J offset of grid sample g: mj (d + B g) + the warp's offset) when params.lsm_affine, and gain and
// offset (template and window normalised); the search image resampled at each step. B absorbs what the
// DEM gets linearly wrong over the patch (its slope, hence the foreshortening), which would otherwise
// pull the translation towards the stronger texture. kOk, kOutside (a sample left J) or kLsmDiverged.
PatchResult refineLeastSquares(const Footprint& sample_j, const Eigen::Vector2d& j_predicted_px,
                               const Eigen::Matrix2d& mj, const std::vector<Eigen::Vector2d>& off_j,
                               const std::vector<double>& tmpl, int h, const PatchParams& params,
                               Eigen::Vector2d& d, Eigen::Matrix2d& b_fix, Eigen::Matrix2d& d_cov) {
  const int side = 2 * h + 1;
  double tm = 0, tv = 0;
  for (double t : tmpl) tm += t;
  tm /= static_cast<double>(tmpl.size());
  for (double t : tmpl) tv += (t - tm) * (t - tm);
  const double tn = std::sqrt(tv);
  std::vector<double> sv(tmpl.size()), gx(tmpl.size()), gy(tmpl.size());
  const Eigen::Vector2d start = d;
  const Eigen::Vector2d ex = mj * Eigen::Vector2d(0.5, 0.0), ey = mj * Eigen::Vector2d(0.0, 0.5);
  const int unknowns = params.lsm_affine ? 6 : 2;
  for (int it = 0; it < params.lsm_iterations; ++it) {
    for (int v = -h; v <= h; ++v) {
      for (int u = -h; u <= h; ++u) {
        const std::size_t k = static_cast<std::size_t>(v + h) * side + (u + h);
        const Eigen::Vector2d p = j_predicted_px + mj * (d + b_fix * Eigen::Vector2d(u, v)) + off_j[k];
        sv[k] = sample_j.at(p.x(), p.y());
        gx[k] = sample_j.at(p.x() + ex.x(), p.y() + ex.y()) - sample_j.at(p.x() - ex.x(), p.y() - ex.y());
        gy[k] = sample_j.at(p.x() + ey.x(), p.y() + ey.y()) - sample_j.at(p.x() - ey.x(), p.y() - ey.y());
        if (!std::isfinite(sv[k]) || !std::isfinite(gx[k]) || !std::isfinite(gy[k]))
          return PatchResult::kOutside;
      }
    }
    double sm = 0, svv = 0;
    for (double s : sv) sm += s;
    sm /= static_cast<double>(sv.size());
    for (double s : sv) svv += (s - sm) * (s - sm);
    const double sn = std::sqrt(std::max(svv, 1e-12));
    // r = tn_k - sn_k(d, B); d(sn_k)/dd = grad / sn (the normalisation's own derivative is second order).
    Eigen::Matrix<double, 6, 6> n = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
    double rr = 0.0;
    for (int v = -h; v <= h; ++v) {
      for (int u = -h; u <= h; ++u) {
        const std::size_t k = static_cast<std::size_t>(v + h) * side + (u + h);
        const double r = (tmpl[k] - tm) / tn - (sv[k] - sm) / sn;
        const double jx = gx[k] / sn, jy = gy[k] / sn;
        Eigen::Matrix<double, 6, 1> j;
        j << jx, jy, jx * u, jx * v, jy * u, jy * v;
        n.noalias() += j * j.transpose();
        rhs += j * r;
        rr += r * r;
      }
    }
    // The translation's covariance (grid steps): the residuals' variance over the redundancy times the
    // inverse normal matrix.
    const double s2 = rr / std::max(1.0, static_cast<double>(tmpl.size()) - unknowns);
    Eigen::Matrix<double, 6, 6> cov = Eigen::Matrix<double, 6, 6>::Zero();
    if (unknowns == 6) {
      cov = s2 * n.inverse();
    } else {
      cov.topLeftCorner<2, 2>() = s2 * n.topLeftCorner<2, 2>().inverse();
    }
    d_cov = cov.topLeftCorner<2, 2>();
    Eigen::Matrix<double, 6, 1> step = Eigen::Matrix<double, 6, 1>::Zero();
    if (unknowns == 6) {
      step = n.ldlt().solve(rhs);
    } else {
      step.head<2>() = n.topLeftCorner<2, 2>().ldlt().solve(rhs.head<2>());
    }
    if (!step.allFinite()) break;
    d += step.head<2>().cwiseMax(-0.5).cwiseMin(0.5);
    const Eigen::Matrix<double, 4, 1> db = step.tail<4>().cwiseMax(-0.05).cwiseMin(0.05);
    b_fix(0, 0) += db[0];
    b_fix(0, 1) += db[1];
    b_fix(1, 0) += db[2];
    b_fix(1, 1) += db[3];
    // The correction stays a correction: a warp off by more than kMaxAffineFix is not this point.
    if ((d - start).cwiseAbs().maxCoeff() > 1.0 || b_fix.cwiseAbs().maxCoeff() > kMaxAffineFix) {
      return PatchResult::kLsmDiverged;
    }
    if (step.head<2>().norm() < 1e-3 && db.cwiseAbs().maxCoeff() < 1e-4) break;
    // Converged when no unknown moves by a tenth of its own standard deviation: a further step changes
    // nothing the match's precision resolves.
    bool settled = step.head<2>().norm() < kSettledSigmas * std::sqrt(d_cov.trace());
    for (int k = 2; k < unknowns; ++k)
      settled = settled && std::fabs(step[k]) < kSettledSigmas * std::sqrt(cov(k, k));
    if (settled) break;
  }
  return PatchResult::kOk;
}

}  // namespace

double samplePyramid(const std::vector<cv::Mat>& pyramid, int level, double x_px, double y_px) {
  return sampleLevel(pyramid[level], 1.0 / (1 << level), x_px, y_px);
}

PatchMatch matchWarpedPatch(const std::vector<cv::Mat>& image_i, const Eigen::Vector2d& i_px,
                            const std::vector<cv::Mat>& image_j, const Eigen::Vector2d& j_predicted_px,
                            const Eigen::Matrix2d& a, const PatchParams& params,
                            const PatchSurface* surface) {
  PatchMatch out;
  const double det = a.determinant();
  if (!std::isfinite(det) || std::fabs(det) < 1e-6) return out;
  // Grid step maps: I offset = mi * g, J offset = mj * g; the coarser image steps one of its pixels.
  Eigen::Matrix2d mi = Eigen::Matrix2d::Identity(), mj = a;
  if (std::fabs(det) < 1.0) {
    mi = a.inverse();
    mj = Eigen::Matrix2d::Identity();
  }
  const Footprint sample_i =
      params.anisotropic
          ? Footprint(image_i, mi)
          : Footprint(image_i, std::sqrt(std::fabs(mi.determinant())) * Eigen::Matrix2d::Identity());
  const Footprint sample_j =
      params.anisotropic
          ? Footprint(image_j, mj)
          : Footprint(image_j, std::sqrt(std::fabs(mj.determinant())) * Eigen::Matrix2d::Identity());
  const int h = params.half;
  const int radius =
      std::max(2, static_cast<int>(std::ceil(params.radius_px / std::sqrt(std::fabs(mj.determinant())))));
  const int side = 2 * h + 1;

  const std::size_t count = static_cast<std::size_t>(side) * side;
  std::vector<double> tmpl(count);
  std::vector<Eigen::Vector2d> off_j(count);
  const double tolerance_px = params.warp_tolerance_steps * std::sqrt(std::fabs(mj.determinant()));
  if (!sampleTemplate(sample_i, i_px, mi, mj, h, surface, tolerance_px, tmpl, off_j)) return out;
  const int ns = 2 * radius + 1;
  std::vector<double> score(static_cast<std::size_t>(ns) * ns, -2.0);
  std::vector<double> window(count);
  // J at full resolution stepped by whole pixels (J the coarser view): each sample keeps its bilinear
  // weights over the whole search, only its pixel moves.
  const bool whole_pixels = mj == Eigen::Matrix2d::Identity() && sample_j.level == 0 && sample_j.taps == 1;
  std::optional<WholePixelWindows> windows;
  std::optional<GridWindows> grid_windows;
  thread_local FootprintGrid grid;
  if (whole_pixels) {
    windows.emplace(image_j[0], j_predicted_px, off_j, tmpl);
  } else {
    grid_windows.emplace(grid, sample_j, j_predicted_px, mj, off_j, radius, tmpl);
  }
  int best_k = -1;
  for (int sy = 0; sy < ns; ++sy) {
    for (int sx = 0; sx < ns; ++sx) {
      const int k = sy * ns + sx;
      const bool inside = windows ? windows->score(sx - radius, sy - radius, score[k])
                                  : grid_windows->score(sx - radius, sy - radius, score[k]);
      // A shift whose window leaves the image is not scored (the search is clipped at the image's edge).
      if (!inside && !params.clip_at_edge) return out;
      if (!inside) score[k] = kUnscored;
      if (inside && (best_k < 0 || score[k] > score[best_k])) best_k = k;
    }
  }
  if (best_k < 0) return out;  // every window leaves the image
  out.ncc = score[best_k];
  if (out.ncc <= -1.5) {
    out.result = PatchResult::kFlat;
    return out;
  }
  const int bx = best_k % ns, by = best_k / ns;
  out.second = secondPeak(score, ns, bx, by);
  if (out.ncc < params.min_ncc) {
    out.result = PatchResult::kLowNcc;
    return out;
  }
  if (out.second > params.max_second_ratio * out.ncc) {
    out.result = PatchResult::kAmbiguous;
    return out;
  }
  if (edgePeak(score, ns, bx, by)) {
    out.result = PatchResult::kEdgePeak;
    return out;
  }
  Eigen::Vector2d d(bx - radius, by - radius);
  Eigen::Matrix2d b_fix = Eigen::Matrix2d::Zero();
  Eigen::Matrix2d d_cov = Eigen::Matrix2d::Zero();
  out.result = refineLeastSquares(sample_j, j_predicted_px, mj, off_j, tmpl, h, params, d, b_fix, d_cov);
  out.cov_px = mj * d_cov * mj.transpose();
  if (out.result != PatchResult::kOk) return out;
  // NCC at the refined position.
  for (int v = -h; v <= h; ++v) {
    for (int u = -h; u <= h; ++u) {
      const std::size_t k = static_cast<std::size_t>(v + h) * side + (u + h);
      const Eigen::Vector2d p = j_predicted_px + mj * (d + b_fix * Eigen::Vector2d(u, v)) + off_j[k];
      window[k] = sample_j.at(p.x(), p.y());
    }
  }
  out.ncc_final = nccOf(tmpl, window);
  out.j_px = j_predicted_px + mj * d;
  return out;
}

}  // namespace areomap::traverse
