#include "ground/dem/EquiParallax.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <stdexcept>

#include <Eigen/Dense>

#include "ground/cli/Parallel.hpp"
#include "ground/dem/MedianGuess.hpp"
#include "ground/dense/LineId.hpp"

namespace areomap::dem {

namespace {

constexpr double kPi = 3.14159265358979323846;

double wrapAngle(double a) {
  while (a > kPi) a -= 2.0 * kPi;
  while (a <= -kPi) a += 2.0 * kPi;
  return a;
}

struct Line {
  double ref_az = 0.0;              // azimuth the relative angles are taken from
  std::vector<double> az, r, z, s;  // sorted by relative azimuth
  double median_r = 0.0;
};

struct Sample {
  double r, z, s;
};

// Interpolates a line at relative azimuth `a`; false when `a` is outside or in a gap.
bool sampleLine(const Line& l, double az, double max_gap, Sample& out) {
  const double a = wrapAngle(az - l.ref_az);
  if (l.az.empty() || a < l.az.front() || a > l.az.back()) return false;
  const auto it = std::lower_bound(l.az.begin(), l.az.end(), a);
  std::size_t j = static_cast<std::size_t>(it - l.az.begin());
  if (j == 0) {
    out = Sample{l.r[0], l.z[0], l.s[0]};
    return true;
  }
  const double a0 = l.az[j - 1], a1 = l.az[j];
  if (a1 - a0 > max_gap) return false;
  const double t = a1 > a0 ? (a - a0) / (a1 - a0) : 0.0;
  out = Sample{l.r[j - 1] + t * (l.r[j] - l.r[j - 1]), l.z[j - 1] + t * (l.z[j] - l.z[j - 1]),
               l.s[j - 1] + t * (l.s[j] - l.s[j - 1])};
  return true;
}

// The lines (sorted by median range) by absolute azimuth: per bucket of kAzimuthBuckets around the circle,
// in increasing order, every line that sampleLine can interpolate at an azimuth in that bucket, with the
// bounds of the ranges it can give there (its segments that reach into the bucket or a bucket beside it,
// no wider than the azimuth gap, so that the rounding of either azimuth cannot move a segment out). A line
// outside a cell's bucket would be refused, and a line whose bounds cannot beat the cell's best line
// below or above cannot change them: a cell reads a few lines and makes the same choice.
constexpr int kAzimuthBuckets = 720;

int azimuthBucket(double az) {
  const int b = static_cast<int>(std::floor((az + kPi) / (2.0 * kPi) * kAzimuthBuckets));
  return std::clamp(b, 0, kAzimuthBuckets - 1);
}

struct AzimuthBucket {
  std::vector<uint32_t> line;        // line indices, increasing
  std::vector<double> r_low, r_high;  // per entry: the ranges the line can give in the bucket
};

std::vector<AzimuthBucket> linesByAzimuth(const std::vector<Line>& lines, double max_gap_rad) {
  std::vector<AzimuthBucket> buckets(kAzimuthBuckets);
  std::vector<double> low, high;  // per bucket of the line's span
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const Line& l = lines[i];
    if (l.az.empty()) continue;
    const int first = azimuthBucket(wrapAngle(l.ref_az + l.az.front())) - 1;
    const int span = std::min(
        kAzimuthBuckets,
        static_cast<int>(std::ceil((l.az.back() - l.az.front()) / (2.0 * kPi) * kAzimuthBuckets)) + 4);
    low.assign(static_cast<std::size_t>(span), std::numeric_limits<double>::infinity());
    high.assign(static_cast<std::size_t>(span), -std::numeric_limits<double>::infinity());
    // Point j with the one before it (j = 0: the first point alone), over the buckets of their azimuths.
    for (std::size_t j = 0; j < l.az.size(); ++j) {
      const std::size_t a = j == 0 ? 0 : j - 1;
      if (l.az[j] - l.az[a] > max_gap_rad) continue;  // sampleLine refuses the gap
      const int b0 = azimuthBucket(wrapAngle(l.ref_az + l.az[a])) - 1;
      const int b1 = azimuthBucket(wrapAngle(l.ref_az + l.az[j])) + 1;
      const double r0 = std::min(l.r[a], l.r[j]), r1 = std::max(l.r[a], l.r[j]);
      for (int b = b0;; ++b) {
        const int k = ((b - first) % kAzimuthBuckets + kAzimuthBuckets) % kAzimuthBuckets;
        if (k < span) {
          low[static_cast<std::size_t>(k)] = std::min(low[static_cast<std::size_t>(k)], r0);
          high[static_cast<std::size_t>(k)] = std::max(high[static_cast<std::size_t>(k)], r1);
        }
        if ((b - b1) % kAzimuthBuckets == 0) break;
      }
    }
    for (int k = 0; k < span; ++k) {
      if (!(low[static_cast<std::size_t>(k)] <= high[static_cast<std::size_t>(k)])) continue;
      AzimuthBucket& bucket = buckets[static_cast<std::size_t>((first + k + kAzimuthBuckets) % kAzimuthBuckets)];
      bucket.line.push_back(static_cast<uint32_t>(i));
      bucket.r_low.push_back(low[static_cast<std::size_t>(k)]);
      bucket.r_high.push_back(high[static_cast<std::size_t>(k)]);
    }
  }
  return buckets;
}

// A point of a pair before it is placed on its line: azimuth (relative to the pair's reference),
// horizontal range, elevation, sigma, and its inverse distance from the ray origin (the disparity up to the
// factor f b and the depth/distance ratio, which varies slowly across the image).
struct RayPoint {
  double az, r, z, s, q;
  std::size_t index;   // in the input points
  double scale = 1.0;  // fitted distance / measured distance
};

// Rows of one pair, each sorted by azimuth.
struct PairRows {
  double ref_az = 0.0;
  std::map<int64_t, std::vector<RayPoint>> rows;  // rectified row -> points
};

// Median azimuth step between neighbouring points of a row (one image column).
double columnStep(const std::vector<RayPoint>& row) {
  std::vector<double> d;
  for (std::size_t i = 1; i < row.size(); ++i) {
    if (row[i].az > row[i - 1].az) d.push_back(row[i].az - row[i - 1].az);
  }
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

// A point's window: its neighbours in the rows within +-row_half (each row's points one run, in row order),
// as columns of their own (col: column offset from the centre point, q: inverse distance, w: weight).
struct FitWindow {
  struct Run {
    int row;                 // row offset from the centre point's row
    std::size_t begin, end;  // its points
  };
  std::vector<Run> runs;
  std::vector<double> col, q, w;
  void clear() {
    runs.clear();
    col.clear();
    q.clear();
    w.clear();
  }
  std::size_t size() const { return q.size(); }
};

// One run's weighted sums: sum w, w col, w col^2, w q, w q col.
struct RunSums {
  double w, wc, wcc, wq, wqc;
};

// The normal equations of q = c0 + c1 col + c2 row + c3 row^2 (the first row_terms + 2 terms; the others'
// diagonal 1, their rows 0) from each run's sums: the row being constant along a run, every sum over the
// window is a sum over the runs of a power of the run's row times one of its five sums. The lower triangle,
// which LDLT reads.
void epNormalEquations(const FitWindow& win, const std::vector<RunSums>& sums, int row_terms,
                       Eigen::Matrix4d& ata, Eigen::Vector4d& atb) {
  double a00 = 0, a10 = 0, a11 = 0, b0 = 0, b1 = 0;
  double a20 = 0, a21 = 0, a22 = 0, a31 = 0, a32 = 0, a33 = 0, b2 = 0, b3 = 0;
  for (std::size_t g = 0; g < sums.size(); ++g) {
    const RunSums& s = sums[g];
    const double d = win.runs[g].row, d2 = d * d;
    a00 += s.w;
    a10 += s.wc;
    a11 += s.wcc;
    b0 += s.wq;
    b1 += s.wqc;
    a20 += d * s.w;
    a21 += d * s.wc;
    a22 += d2 * s.w;
    a31 += d2 * s.wc;
    a32 += d2 * d * s.w;
    a33 += d2 * d2 * s.w;
    b2 += d * s.wq;
    b3 += d2 * s.wq;
  }
  ata.setZero();
  atb.setZero();
  ata(0, 0) = a00;
  ata(1, 0) = a10;
  ata(1, 1) = a11;
  atb(0) = b0;
  atb(1) = b1;
  if (row_terms >= 1) {
    ata(2, 0) = a20;
    ata(2, 1) = a21;
    ata(2, 2) = a22;
    atb(2) = b2;
  }
  if (row_terms >= 2) {
    ata(3, 0) = a22;
    ata(3, 1) = a31;
    ata(3, 2) = a32;
    ata(3, 3) = a33;
    atb(3) = b3;
  }
  for (int k = row_terms + 2; k < 4; ++k) ata(k, k) = 1.0;  // unused terms
}

// Each run's weighted sums into `sums`.
void epRunSums(const FitWindow& win, std::vector<RunSums>& sums) {
  sums.resize(win.runs.size());
  for (std::size_t g = 0; g < win.runs.size(); ++g) {
    double sw = 0, swc = 0, swcc = 0, swq = 0, swqc = 0;
    for (std::size_t k = win.runs[g].begin; k < win.runs[g].end; ++k) {
      const double w = win.w[k], wc = w * win.col[k];
      sw += w;
      swc += wc;
      swcc += wc * win.col[k];
      swq += w * win.q[k];
      swqc += wc * win.q[k];
    }
    sums[g] = RunSums{sw, swc, swcc, swq, swqc};
  }
}

// The weighted least-squares coefficients c of the run sums' normal equations, their factorisation in
// `ldlt`; false when the window cannot be fitted (too little weight, not positive definite, not finite).
bool epSolve(const FitWindow& win, const std::vector<RunSums>& sums, int row_terms,
             Eigen::LDLT<Eigen::Matrix4d>& ldlt, Eigen::Vector4d& c) {
  Eigen::Matrix4d ata;
  Eigen::Vector4d atb;
  epNormalEquations(win, sums, row_terms, ata, atb);
  if (ata(0, 0) < 3.0) return false;
  ldlt.compute(ata);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return false;
  c = ldlt.solve(atb);
  return c.allFinite();
}

// Fit q = c0 + c1 col [+ c2 row [+ c3 row^2]] (row_terms 0, 1 or 2) of the window, then `iterations`
// reweightings with Tukey's biweight (c = 4.685 robust sigmas, the sigma from the median absolute
// residual): mismatches (the disparity errors are heavy-tailed, ~6 % above 1 px on a rendered navcam pair)
// get no weight. With row_terms 2 the row^2 term is dropped at the end unless it is significant. False
// when the window cannot be fitted. The weights are left in `win`.
bool robustAffineFit(FitWindow& win, int row_terms, int iterations, std::vector<double>& res,
                     std::vector<RunSums>& sums, MedianGuess& guess, double& c0) {
  if (win.size() < 5) return false;
  Eigen::Vector4d c = Eigen::Vector4d::Zero();
  for (int iter = 0; iter <= iterations; ++iter) {
    epRunSums(win, sums);
    Eigen::LDLT<Eigen::Matrix4d> ldlt;
    if (!epSolve(win, sums, row_terms, ldlt, c)) return false;
    if (iter == iterations && row_terms == 2) {
      // The row^2 term only where the curvature is significant (|c3| > 2 of its standard deviations, from
      // the weighted residuals); elsewhere it would only add variance: refit without it, same weights (the
      // same run sums).
      double ss = 0.0, sw = 0.0;
      for (const FitWindow::Run& run : win.runs) {
        const double base = c(0) + run.row * (c(2) + run.row * c(3));
        for (std::size_t k = run.begin; k < run.end; ++k) {
          const double r = win.q[k] - (base + c(1) * win.col[k]);
          ss += win.w[k] * r * r;
          sw += win.w[k];
        }
      }
      const double var_c3 = ss / std::max(1.0, sw - 4.0) * ldlt.solve(Eigen::Vector4d::UnitW())(3);
      if (c(3) * c(3) > 4.0 * var_c3) break;
      if (!epSolve(win, sums, 1, ldlt, c)) return false;
      break;
    }
    if (iter == iterations) break;
    res.resize(win.size());
    for (const FitWindow::Run& run : win.runs) {
      const double base = c(0) + run.row * (c(2) + run.row * c(3));
      for (std::size_t k = run.begin; k < run.end; ++k)
        res[k] = std::fabs(win.q[k] - (base + c(1) * win.col[k]));
    }
    const double scale = 4.685 * 1.4826 * guess.median(res, iter);
    if (scale <= 0.0) break;
    const double inv_scale = 1.0 / scale;
    for (std::size_t k = 0; k < win.size(); ++k) {
      const double u = res[k] * inv_scale;
      const double v = std::max(0.0, 1.0 - u * u);  // 0 from u = 1 on (and for NaN)
      win.w[k] = v * v;
    }
  }
  c0 = c(0);
  return c0 > 0.0;
}

// Replaces each point's inverse distance q by a local affine fit q = c0 + c1 column + c2 row over the
// points within +-col_half columns and +-row_half rows (a plane is an affine disparity field in a
// rectified pair, and the disparity noise is the same everywhere), then moves the point along its own ray
// (through the ray origin) to the fitted distance: the range error, which lies along the ray, is averaged
// in the domain where the regressors (row, column) are exact.
void fitInverseDistance(PairRows& pr, int col_half, int row_half, bool quadratic_in_row,
                        int robust_iterations, double origin_up_m) {
  std::map<int64_t, double> steps;
  for (const auto& kv : pr.rows) steps[kv.first] = columnStep(kv.second);
  // The rows are fitted in parallel (row k by thread k mod T); each reads the measured q of its neighbours
  // and writes only its own fitted values, so the result does not depend on the thread count.
  std::map<int64_t, std::vector<double>> fitted;
  std::vector<std::map<int64_t, std::vector<RayPoint>>::const_iterator> order;
  for (auto it = pr.rows.cbegin(); it != pr.rows.cend(); ++it) {
    order.push_back(it);
    fitted[it->first];
  }
  const int threads =
      static_cast<int>(std::min<std::size_t>(cli::threadCount(), std::max<std::size_t>(1, order.size())));
  const auto work = [&](std::size_t t) {
    FitWindow window;
    std::vector<double> residuals;
    std::vector<RunSums> sums;
    for (std::size_t k = t; k < order.size(); k += static_cast<std::size_t>(threads)) {
      const auto& kv = *order[k];
      const std::vector<RayPoint>& row = kv.second;
      const double step = steps.at(kv.first);
      MedianGuess guess;  // per row: its points' windows follow one another
      std::vector<double>& out = fitted.at(kv.first);
      out.resize(row.size());
      for (std::size_t i = 0; i < row.size(); ++i) out[i] = row[i].q;
      if (step <= 0.0 || col_half <= 0) continue;
      const double w = col_half * step;
      for (std::size_t i = 0; i < row.size(); ++i) {
        const double a = row[i].az;
        window.clear();
        int below = 0, above = 0;
        for (auto it = pr.rows.lower_bound(kv.first - row_half);
             it != pr.rows.end() && it->first <= kv.first + row_half; ++it) {
          const std::vector<RayPoint>& nb = it->second;
          auto lo = std::lower_bound(nb.begin(), nb.end(), a - w,
                                     [](const RayPoint& p, double v) { return p.az < v; });
          const int d = static_cast<int>(it->first - kv.first);
          const std::size_t begin = window.size();
          for (auto p = lo; p != nb.end() && p->az <= a + w; ++p) {
            window.col.push_back((p->az - a) / step);
            window.q.push_back(p->q);
            window.w.push_back(1.0);
          }
          if (window.size() == begin) continue;
          window.runs.push_back(FitWindow::Run{d, begin, window.size()});
          below = std::max(below, -d);
          above = std::max(above, d);
        }
        // Rows used: 1 = this row only, fit along it; 2 = affine across rows; 3 or more = a row^2 term too,
        // kept only where it is significant.
        const int spread = below + above;
        const int row_terms = spread >= 2 && quadratic_in_row ? 2 : std::min(spread, 1);
        double c0 = 0.0;
        if (robustAffineFit(window, row_terms, robust_iterations, residuals, sums, guess, c0)) out[i] = c0;
      }
    }
  };
  cli::parallelFor(static_cast<std::size_t>(threads), threads, work);
  for (auto& kv : pr.rows) {
    const std::vector<double>& f = fitted[kv.first];
    for (std::size_t i = 0; i < kv.second.size(); ++i) {
      RayPoint& p = kv.second[i];
      const double k = p.q / f[i];  // new distance / old distance
      p.scale = k;
      p.r *= k;
      p.z = origin_up_m + (p.z - origin_up_m) * k;
    }
  }
}

// The points with a line id beyond seam - blend - max_range_gap (so that the first lines bracket the
// blend zone), grouped by pair and rectified row (dense::lineId), each row sorted by azimuth.
std::vector<PairRows> groupRows(const std::vector<DemPoint>& points, const EquiParallaxOptions& o) {
  const double r_min = o.seam_m - o.blend_m - o.max_range_gap_m;
  std::map<int64_t, std::vector<std::size_t>> by_pair;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const DemPoint& p = points[i];
    if (p.line < 0) continue;
    if (std::hypot(p.north_m - o.centre_north_m, p.east_m - o.centre_east_m) < r_min) continue;
    by_pair[dense::linePair(p.line)].push_back(i);
  }
  std::vector<PairRows> out;
  for (auto& g : by_pair) {
    PairRows pr;
    double sx = 0.0, sy = 0.0;
    for (std::size_t i : g.second) {
      const double a = std::atan2(points[i].east_m - o.centre_east_m, points[i].north_m - o.centre_north_m);
      sx += std::cos(a);
      sy += std::sin(a);
    }
    pr.ref_az = std::atan2(sy, sx);
    for (std::size_t i : g.second) {
      const DemPoint& p = points[i];
      const double dn = p.north_m - o.centre_north_m, de = p.east_m - o.centre_east_m;
      const double r = std::hypot(dn, de);
      const double rho = std::hypot(r, p.elevation_m - o.centre_up_m);
      if (rho <= 0.0) continue;
      pr.rows[dense::lineRow(p.line)].push_back(RayPoint{wrapAngle(std::atan2(de, dn) - pr.ref_az), r,
                                                        p.elevation_m, p.sigma_m, 1.0 / rho, i});
    }
    for (auto& kv : pr.rows) {
      std::sort(kv.second.begin(), kv.second.end(),
                [](const RayPoint& x, const RayPoint& y) { return x.az < y.az; });
    }
    out.push_back(std::move(pr));
  }
  return out;
}

// groupRows, each pair's points moved along their rays by fitInverseDistance with the options' window.
std::vector<PairRows> fittedRows(const std::vector<DemPoint>& points, const EquiParallaxOptions& o) {
  std::vector<PairRows> pairs = groupRows(points, o);
  for (PairRows& pr : pairs) {
    fitInverseDistance(pr, o.smoothing_half_window, o.row_half_window, o.quadratic_in_row,
                       o.robust_iterations, o.centre_up_m);
  }
  return pairs;
}

}  // namespace

std::vector<DemPoint> fitAlongRays(const std::vector<DemPoint>& points, const EquiParallaxOptions& o) {
  std::vector<DemPoint> out = points;
  for (const PairRows& pr : fittedRows(points, o)) {
    for (const auto& kv : pr.rows) {
      for (const RayPoint& rp : kv.second) {
        DemPoint& p = out[rp.index];
        p.north_m = o.centre_north_m + (p.north_m - o.centre_north_m) * rp.scale;
        p.east_m = o.centre_east_m + (p.east_m - o.centre_east_m) * rp.scale;
        p.elevation_m = o.centre_up_m + (p.elevation_m - o.centre_up_m) * rp.scale;
      }
    }
  }
  return out;
}

DemGrid equiParallaxDem(const std::vector<DemPoint>& points, const DemGrid& grid,
                        const EquiParallaxOptions& o, DemGrid* sigma) {
  if (grid.cols <= 0 || grid.rows <= 0) throw std::invalid_argument("equi-parallax: bad grid");
  DemGrid out = grid;
  out.values.assign(static_cast<std::size_t>(grid.cols) * grid.rows, grid.nodata);
  if (sigma != nullptr) *sigma = out;
  const double r_min = o.seam_m - o.blend_m;
  std::vector<Line> lines;
  for (const PairRows& pr : fittedRows(points, o)) {
    for (const auto& kv : pr.rows) {
      if (kv.second.size() < 2) continue;
      Line l;
      l.ref_az = pr.ref_az;
      for (const RayPoint& p : kv.second) {
        l.az.push_back(p.az);
        l.r.push_back(p.r);
        l.z.push_back(p.z);
        l.s.push_back(p.s);
      }
      std::vector<double> rr = l.r;
      std::nth_element(rr.begin(), rr.begin() + rr.size() / 2, rr.end());
      l.median_r = rr[rr.size() / 2];
      lines.push_back(std::move(l));
    }
  }
  std::sort(lines.begin(), lines.end(), [](const Line& a, const Line& b) { return a.median_r < b.median_r; });
  std::vector<double> medians(lines.size());
  for (std::size_t i = 0; i < lines.size(); ++i) medians[i] = lines[i].median_r;

  const std::vector<AzimuthBucket> by_azimuth = linesByAzimuth(lines, o.max_azimuth_gap_rad);
  // Rows in parallel: a cell reads the lines and writes only itself.
  cli::parallelFor(static_cast<std::size_t>(grid.rows), 0, [&](std::size_t row_index) {
    const int row = static_cast<int>(row_index);
    const double dn = grid.northOfRow(row) - o.centre_north_m;
    for (int col = 0; col < grid.cols; ++col) {
      const double de = grid.eastOfCol(col) - o.centre_east_m;
      const double r = std::hypot(dn, de);
      if (r < r_min) continue;
      const double az = std::atan2(de, dn);
      const std::size_t lo = static_cast<std::size_t>(
          std::lower_bound(medians.begin(), medians.end(), r - o.max_range_gap_m) - medians.begin());
      const std::size_t hi = static_cast<std::size_t>(
          std::upper_bound(medians.begin(), medians.end(), r + o.max_range_gap_m) - medians.begin());
      bool have_below = false, have_above = false;
      Sample below{0, 0, 0}, above{0, 0, 0};
      // The lines with index in [lo, hi) that hold the cell's azimuth: the best below (the largest range
      // at most r, the first line of the largest) and above (the smallest beyond r, the first line of the
      // smallest), each line skipped whose bounds cannot make it so (eps: the interpolation's rounding).
      const AzimuthBucket& near = by_azimuth[static_cast<std::size_t>(azimuthBucket(az))];
      const std::size_t first = static_cast<std::size_t>(
          std::lower_bound(near.line.begin(), near.line.end(), lo) - near.line.begin());
      const std::size_t last = static_cast<std::size_t>(
          std::lower_bound(near.line.begin(), near.line.end(), hi) - near.line.begin());
      const double eps = 1e-9 * (1.0 + r);
      for (std::size_t k = last; k-- > first;) {  // the last line of a tie seen first: ">=" keeps the first
        if (near.r_low[k] > r + eps || (have_below && near.r_high[k] + eps < below.r)) continue;
        Sample s;
        if (!sampleLine(lines[near.line[k]], az, o.max_azimuth_gap_rad, s) || !(s.r <= r)) continue;
        if (!have_below || s.r >= below.r) below = s;
        have_below = true;
      }
      for (std::size_t k = first; k < last; ++k) {
        if (near.r_high[k] + eps < r || (have_above && near.r_low[k] - eps > above.r)) continue;
        Sample s;
        if (!sampleLine(lines[near.line[k]], az, o.max_azimuth_gap_rad, s) || s.r <= r) continue;
        if (!have_above || s.r < above.r) above = s;
        have_above = true;
      }
      if (!have_below || !have_above || above.r - below.r > o.max_range_gap_m) continue;
      const double t = above.r > below.r ? (r - below.r) / (above.r - below.r) : 0.0;
      out.at(col, row) = static_cast<float>(below.z + t * (above.z - below.z));
      if (sigma != nullptr) sigma->at(col, row) = static_cast<float>(below.s + t * (above.s - below.s));
    }
  });
  return out;
}

namespace {

// The far range's weight in the blend at a cell of `g`.
double farWeight(const DemGrid& g, int col, int row, const EquiParallaxOptions& o) {
  const double r = std::hypot(g.northOfRow(row) - o.centre_north_m, g.eastOfCol(col) - o.centre_east_m);
  return o.blend_m > 0.0 ? std::clamp((r - (o.seam_m - o.blend_m)) / (2.0 * o.blend_m), 0.0, 1.0)
                         : (r >= o.seam_m ? 1.0 : 0.0);
}

}  // namespace

// With weight 1 a kriged value kz becomes (1 - 1) kz + 1 fz = fz, as where there is none.
std::vector<uint8_t> cellsBlendKeeps(const DemGrid& far, const EquiParallaxOptions& o) {
  std::vector<uint8_t> keeps(static_cast<std::size_t>(far.cols) * far.rows, 1);
  for (int row = 0; row < far.rows; ++row) {
    for (int col = 0; col < far.cols; ++col) {
      if (far.at(col, row) != far.nodata && farWeight(far, col, row, o) >= 1.0)
        keeps[static_cast<std::size_t>(row) * far.cols + col] = 0;
    }
  }
  return keeps;
}

void blendFarRange(KrigingResult& kriged, const DemGrid& far, const DemGrid* far_sigma,
                   const EquiParallaxOptions& o) {
  DemGrid& z = kriged.elevation;
  DemGrid& s = kriged.sigma;
  if (far.cols != z.cols || far.rows != z.rows) throw std::invalid_argument("blendFarRange: grids differ");
  for (int row = 0; row < z.rows; ++row) {
    for (int col = 0; col < z.cols; ++col) {
      const double w = farWeight(z, col, row, o);
      if (w <= 0.0) continue;
      const float fz = far.at(col, row);
      if (fz == far.nodata) continue;
      const float kz = z.at(col, row);
      if (kz == z.nodata) {
        z.at(col, row) = fz;
        if (far_sigma != nullptr) s.at(col, row) = far_sigma->at(col, row);
        continue;
      }
      z.at(col, row) = static_cast<float>((1.0 - w) * kz + w * fz);
      if (far_sigma != nullptr) {
        s.at(col, row) = static_cast<float>((1.0 - w) * s.at(col, row) + w * far_sigma->at(col, row));
      }
    }
  }
}

}  // namespace areomap::dem
