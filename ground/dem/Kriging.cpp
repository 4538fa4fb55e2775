#include "ground/dem/Kriging.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "ground/cli/Parallel.hpp"
#include "ground/dem/KdTree.hpp"
#include "ground/dem/KrigingSystem.hpp"
#include "ground/dem/PointClusters.hpp"
#include "ground/dense/LineId.hpp"

namespace areomap::dem {

namespace {

double nowS() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

constexpr int kGapSample = 2000;  // points sampled for the automatic gap limit
// The automatic gap limit: this many point spacings (the distance to the kSpacingNeighbour-th nearest point,
// the point itself counted), so that a cell between the rows of points that one image row leaves on the
// ground is within reach of them.
constexpr double kGapSpacings = 3.0;
constexpr int kSpacingNeighbour = 8;
constexpr std::size_t kReachBlock = 4096;     // points per task of pointReaches
constexpr double kLagPerNeighbourhood = 3.0;  // automatic variogram extent, in neighbourhood radii

constexpr int kCalibrationSample = 400;  // points of the leave-one-out sigma calibration
constexpr int kMinCalibrationPoints = 30;

// The error variance of a cell's estimate sum_i w_i z_i when the points' errors are correlated
// (Kriging.hpp): the interpolation variance under the SIGNAL variogram (fitted to the robust experimental
// variogram less the points' noise semivariances: the noise-free surface), its nugget filtered (treated
// as measurement error that the point sigmas do not explain, independent from point to point):
//   2 sum_i w_i g(d_i0) - sum_ij w_i w_j g(d_ij),  g = the partial sill's part of gamma_s  (sum_i w_i = 1)
// plus Var(sum_i w_i e_i) = sum_ij w_i w_j s_i s_j rho_ij (s_i the point's own sigma) + nugget sum_i w_i^2.
struct CorrelatedNoise {
  double l_px = 0.0;
  double q = 0.0;  // exp(-1 / l_px), once (patchCorrelation)
  const std::vector<float>* gsd = nullptr;
  double bin_m = 0.0;
  VariogramModel signal;
  const std::vector<float>* extra = nullptr;      // KrigingOptions::point_extra_var_m2 (or none)
  const std::vector<float>* pair_sd = nullptr;    // KrigingOptions::point_pair_sd_m (or none)
  const std::vector<double>* local_sd = nullptr;  // with pair_sd: per point, sqrt(sigma^2 - pair_sd^2)

  bool on() const { return l_px > 0.0 && gsd != nullptr; }

  static bool samePair(const DemPoint& a, const DemPoint& b) {
    return !(a.line >= 0 && b.line >= 0 && dense::linePair(a.line) != dense::linePair(b.line));
  }

  // Of two points of one pair (samePair).
  double rho(const DemPoint& a, const DemPoint& b, double gsd_a, double gsd_b) const {
    const double g = std::max(1e-6, 0.5 * (gsd_a + gsd_b));
    return patchCorrelation(std::fabs(a.north_m - b.north_m) / g, std::fabs(a.east_m - b.east_m) / g,
                            std::max(1.0, bin_m / g), l_px, q);
  }

  // Cov(e_i, e_j) of two different points.
  double noiseCovariance(const std::vector<DemPoint>& points, std::size_t i, std::size_t j) const {
    const DemPoint &a = points[i], &b = points[j];
    if (!samePair(a, b)) return 0.0;  // other images
    const double r = rho(a, b, (*gsd)[i], (*gsd)[j]);
    if (pair_sd == nullptr) return a.sigma_m * b.sigma_m * r;
    return (r != 0.0 ? (*local_sd)[i] * (*local_sd)[j] * r : 0.0) +
           static_cast<double>((*pair_sd)[i]) * (*pair_sd)[j];
  }

  // 1/2 Var(e_i - e_j): what the noise adds to the pair's semivariance.
  double pairNoise(const std::vector<DemPoint>& points, std::size_t i, std::size_t j) const {
    const DemPoint &a = points[i], &b = points[j];
    return 0.5 * (a.sigma_m * a.sigma_m + b.sigma_m * b.sigma_m) - noiseCovariance(points, i, j);
  }

  // The signal's semivariance without its nugget (filtered kriging: the nugget is measurement error).
  double filtered(double h) const { return signal.partial_sill_m2 * (1.0 - signal.correlationFast(h)); }

  // A pair's part of the double sum: Cov(e_i, e_j) - g(d_ij) (symmetric in i and j, bit for bit).
  double pairTerm(const std::vector<DemPoint>& points, std::size_t pi, std::size_t pj) const {
    const DemPoint &a = points[pi], &b = points[pj];
    const double dn = a.north_m - b.north_m, de = a.east_m - b.east_m;
    const double h = std::sqrt(dn * dn + de * de);  // not std::hypot: no overflow to guard, a fraction of its cost
    return noiseCovariance(points, pi, pj) - filtered(h);
  }

  // The pair terms come from `terms` (the set's PairTable, filled by pairTerm; `position`: where each
  // neighbour stands in it): a pair that stays in the next cell's neighbourhood is not evaluated again.
  double variance(const std::vector<DemPoint>& points, int f, const int32_t* idx, const double* d2,
                  const double* w, const PairTable& terms, const int* position) const {
    double v = 0.0;
    for (int i = 0; i < f; ++i) {
      const DemPoint& a = points[static_cast<std::size_t>(idx[i])];
      const double own = extra != nullptr ? (*extra)[static_cast<std::size_t>(idx[i])] : 0.0;
      v += 2.0 * w[i] * filtered(std::sqrt(d2[i])) +
           w[i] * w[i] * (a.sigma_m * a.sigma_m + signal.nugget_m2 + own);
      for (int j = 0; j < i; ++j) {
        const int pi = position[i], pj = position[j];
        v += 2.0 * w[i] * w[j] * (pi > pj ? terms.row(pi)[pj] : terms.row(pj)[pi]);
      }
    }
    return v;
  }
};

// Along one axis: the mean correlation within a segment of m pixels (g) for pixel correlation q^|k|,
// q = exp(-1 / L), qm = q^m.
double segmentVariance(double m, double q, double qm) {
  const double s = q * (m * (1.0 - q) - 1.0 + qm) / ((1.0 - q) * (1.0 - q));
  return (m + 2.0 * s) / (m * m);
}

// One ordinary-kriging solve (covariance form with the Lagrange row) for a query whose neighbours and
// their squared distances are given: KrigingSystem (Cholesky of the covariance block, the Lagrange row by
// its Schur complement, the factorisation reused for cells with the same neighbour set). One per thread.
// With correlated noise (CorrelatedNoise::on) the variance is CorrelatedNoise::variance of the weights.
struct Solver {
  const std::vector<DemPoint>& points;
  KrigingSystem system;
  CorrelatedNoise correlated;
  PairTable pair_terms;  // CorrelatedNoise::pairTerm of the neighbour set, kept from cell to cell

  double noise(const DemPoint& p) const { return system.noise(p); }

  double w[kMaxNeighbours + 1];  // the last solve's weights, then the Lagrange multiplier w[f]

  bool solve(int f, const int32_t* idx, const double* d2, double& z, double& var) {
    double c[kMaxNeighbours];  // covariances with the query
    if (!system.solve(f, idx, d2, w, c)) return false;
    z = 0.0;
    double lc = 0.0;
    for (int i = 0; i < f; ++i) {
      const DemPoint& p = points[static_cast<std::size_t>(idx[i])];
      z += w[i] * p.elevation_m;
      lc += w[i] * c[i];
    }
    var = std::max(0.0, system.partialSill() - lc - w[f]);
    if (correlated.on()) {
      pair_terms.update(f, system.canonicalSet(), [this](int32_t a, int32_t b) {
        return a == b ? 0.0
                      : correlated.pairTerm(points, static_cast<std::size_t>(a), static_cast<std::size_t>(b));
      });
      const double v = correlated.variance(points, f, idx, d2, w, pair_terms, system.canonicalPositions());
      var = std::max(0.0, v);
    }
    return std::isfinite(z) && std::isfinite(var);
  }
};

// The points' coordinates as the search structures and the variogram take them: x north, y east, z up.
struct PointCoordinates {
  std::vector<double> x, y, z;
};

PointCoordinates coordinatesOf(const std::vector<DemPoint>& points) {
  PointCoordinates c;
  c.x.resize(points.size());
  c.y.resize(points.size());
  c.z.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    c.x[i] = points[i].north_m;
    c.y[i] = points[i].east_m;
    c.z[i] = points[i].elevation_m;
  }
  return c;
}

// Point spacing: the median distance to the 8th and to the k-th neighbour over a sample of points.
struct PointSpacing {
  double to_8th_m = 0.0;
  double to_kth_m = 0.0;
};

PointSpacing pointSpacing(const KdTree2& tree, const PointCoordinates& xyz, int k) {
  std::vector<double> s8, sk;
  const std::size_t n = xyz.x.size();
  const std::size_t step = std::max<std::size_t>(1, n / kGapSample);
  int32_t idx[kMaxNeighbours];
  double d2[kMaxNeighbours];
  for (std::size_t i = 0; i < n; i += step) {
    const int f = tree.nearest(xyz.x[i], xyz.y[i], k, idx, d2);
    if (f > 0) {
      s8.push_back(std::sqrt(d2[std::min(f, kSpacingNeighbour) - 1]));
      sk.push_back(std::sqrt(d2[f - 1]));
    }
  }
  std::nth_element(s8.begin(), s8.begin() + s8.size() / 2, s8.end());
  std::nth_element(sk.begin(), sk.begin() + sk.size() / 2, sk.end());
  return PointSpacing{s8[s8.size() / 2], sk[sk.size() / 2]};
}

// The variogram matters at the scale of the kriging neighbourhoods: fit it there (at most a third of the
// points' extent).
double automaticMaxLag(const std::vector<DemPoint>& points, double cell_m, double spacing_k_m) {
  const DemGrid box = gridAround(points, cell_m);
  return std::min(std::hypot(box.cols * box.cell_m, box.rows * box.cell_m) / 3.0,
                  kLagPerNeighbourhood * std::max(spacing_k_m, cell_m));
}

// The k nearest points of (qx, qy), nearest first, as KdTree2::nearest gives them; `f` holds the count of
// the last query's neighbours on entry (in idx, d2), a query near this one. Those k neighbours lie within
// `bound` of this query, so its k-th distance is at most that: the buckets within it give the neighbours
// when they are unique (else the k-d tree, which also skips the nodes beyond the bound): the same
// neighbours, found sooner.
int nearestAfter(const KdTree2& tree, const PointBuckets& buckets, const PointCoordinates& xyz, int k,
                 double qx, double qy, int f, int32_t* idx, double* d2) {
  double bound = 1e300;
  if (f == k) {
    bound = 0.0;
    for (int i = 0; i < f; ++i) {
      const std::size_t j = static_cast<std::size_t>(idx[i]);
      const double dn = xyz.x[j] - qx, de = xyz.y[j] - qy;
      bound = std::max(bound, dn * dn + de * de);
    }
    f = buckets.nearestWithin(qx, qy, k, bound, idx, d2);
  }
  if (f != k) f = tree.nearest(qx, qy, k, idx, d2, bound);
  return f;
}

// Per point: its reach, the distance from it within which it supports a cell (Kriging.hpp,
// KrigingOptions::local_reach): kGapSpacings times its own spacing (the distance to its kSpacingNeighbour-th
// neighbour, itself counted, as the whole cloud's spacing is taken), at least the cloud's gap limit `gap_m`.
// The points taken in the k-d tree's leaf order, each one's neighbours found from the one before it in its
// block (a leaf's points lie near each other: a point's neighbours near the last one's).
std::vector<float> pointReaches(const KdTree2& tree, const PointBuckets& buckets, const PointCoordinates& xyz,
                                double gap_m) {
  std::vector<float> reach(xyz.x.size(), static_cast<float>(gap_m));
  cli::parallelFor((xyz.x.size() + kReachBlock - 1) / kReachBlock, 0, [&](std::size_t block) {
    int32_t idx[kSpacingNeighbour];
    double d2[kSpacingNeighbour];
    int f = 0;
    for (std::size_t j = block * kReachBlock; j < std::min(xyz.x.size(), (block + 1) * kReachBlock); ++j) {
      const std::size_t i = static_cast<std::size_t>(tree.leafIndex(j));
      f = nearestAfter(tree, buckets, xyz, kSpacingNeighbour, xyz.x[i], xyz.y[i], f, idx, d2);
      if (f > 0) reach[i] = static_cast<float>(std::max(gap_m, kGapSpacings * std::sqrt(d2[f - 1])));
    }
  });
  return reach;
}

// Per point: whether it belongs to a cluster of at least `min_cluster_points` (points `gap_m` apart at most);
// `isolated` counts those that do not. The cloud's gap, not the points' own reaches: a lone point or a
// small clump has a wide reach of its own (its neighbours are far), and would link to others like it. Where
// the cloud thins out with range its points still form chains along the image rows that made them, at
// the cloud's gap.
std::vector<uint8_t> supportedPoints(const PointCoordinates& xyz, double gap_m, int min_cluster_points,
                                     long long& isolated) {
  std::vector<uint8_t> supported(xyz.x.size(), 1);
  if (min_cluster_points > 1) {
    const std::vector<int32_t> size = clusterSizes(xyz.x, xyz.y, gap_m);
    for (std::size_t i = 0; i < supported.size(); ++i) {
      supported[i] = size[i] >= min_cluster_points;
      isolated += !supported[i];
    }
  }
  return supported;
}

// The options' per-point noise inputs that match the points (the others left out); local_sd and the signal
// variogram are set by the caller.
CorrelatedNoise correlatedNoiseOf(const std::vector<DemPoint>& points, const KrigingOptions& o) {
  const auto matching = [&](const auto* per_point) {
    return per_point != nullptr && per_point->size() == points.size() ? per_point : nullptr;
  };
  const double l_px = o.noise_correlation_px;
  return CorrelatedNoise{l_px,
                         l_px > 0.0 ? std::exp(-1.0 / l_px) : 0.0,
                         matching(o.point_gsd_m),
                         o.bin_cell_m,
                         VariogramModel{},
                         matching(o.point_extra_var_m2),
                         matching(o.point_pair_sd_m),
                         nullptr};
}

// Per point: sqrt(sigma^2 - pair_sd^2), its noise sd less the part its whole pair shares.
std::vector<double> localNoiseSd(const std::vector<DemPoint>& points, const std::vector<float>& pair_sd) {
  std::vector<double> local_sd(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double c = pair_sd[i];
    local_sd[i] = std::sqrt(std::max(0.0, points[i].sigma_m * points[i].sigma_m - c * c));
  }
  return local_sd;
}

// What every solve reads: the points, their search structures, their support and the variogram.
struct CellInputs {
  const std::vector<DemPoint>& points;
  const PointCoordinates& xyz;  // of the points
  const KdTree2& tree;
  const PointBuckets& buckets;
  const std::vector<uint8_t>& supported;
  const std::vector<float>* reach;  // per point (pointReaches), or none: gap_m for every point
  int k;
  double gap_m;
  double max_reach_m;  // the largest reach of any point (gap_m without per-point reaches)
  const VariogramModel& model;
  bool use_point_sigma;
  const CorrelatedNoise& correlated;
  const std::vector<PointPairs>* point_pairs;  // with shared_error: KrigingOptions'
  const SharedHeightError* shared_error;
  const std::vector<uint8_t>* wanted;  // KrigingOptions::cells (or none: every cell)

  Solver solver() const {
    return Solver{points, KrigingSystem(points, model, use_point_sigma), correlated, PairTable(), {}};
  }
};

// Sigma calibration by leave-one-out cross-validation on a sample of points: the kriging variance plus the
// point's noise should explain the squared LOO error on average; the ratio scales every sigma.
double calibrateSigmaScale(const CellInputs& in, const PointCoordinates& xyz) {
  Solver solver = in.solver();
  int32_t idx[kMaxNeighbours + 1];
  double d2[kMaxNeighbours + 1];
  double sum_ratio = 0.0;
  long long used = 0;
  const std::vector<DemPoint>& points = in.points;
  const std::size_t step = std::max<std::size_t>(1, points.size() / kCalibrationSample);
  for (std::size_t i = 0; i < points.size(); i += step) {
    const int f = in.tree.nearest(xyz.x[i], xyz.y[i], in.k + 1, idx, d2);
    // Drop the point itself (and exact duplicates of its position).
    int g = 0;
    for (int j = 0; j < f; ++j) {
      if (static_cast<std::size_t>(idx[j]) == i) continue;
      idx[g] = idx[j];
      d2[g] = d2[j];
      ++g;
    }
    double z = 0.0, var = 0.0;
    if (g == 0 || !solver.solve(g, idx, d2, z, var)) continue;
    const double noise = solver.noise(points[i]);
    const double e = points[i].elevation_m - z;
    if (var + noise <= 0.0) continue;
    sum_ratio += e * e / (var + noise);
    ++used;
  }
  return used >= kMinCalibrationPoints ? std::sqrt(sum_ratio / static_cast<double>(used)) : 1.0;
}

// What one thread's rows counted.
struct RowCounts {
  long long kriged = 0, unsupported = 0, factorisations = 0, reuses = 0;
};

// Rows first_row, first_row + row_step, ... of the grid into res.elevation and res.sigma.
RowCounts krigeRows(const CellInputs& in, const DemGrid& grid, int first_row, int row_step,
                    KrigingResult& res) {
  Solver s = in.solver();
  RowCounts counts;
  int32_t idx[kMaxNeighbours + 1];
  double d2[kMaxNeighbours + 1];
  const double max_reach2 = in.max_reach_m * in.max_reach_m;
  for (int row = first_row; row < grid.rows; row += row_step) {
    const double qn = grid.northOfRow(row);
    int f = 0;
    const uint8_t* wanted =
        in.wanted != nullptr ? in.wanted->data() + static_cast<std::size_t>(row) * grid.cols : nullptr;
    for (int col = 0; col < grid.cols; ++col) {
      // After a skipped cell the last searched one may lie far away, and its neighbours would bound the
      // next search loosely: that search starts afresh (the k-d tree).
      if (wanted != nullptr && wanted[col] == 0) {
        f = 0;
        continue;
      }
      const double qe = grid.eastOfCol(col);
      f = nearestAfter(in.tree, in.buckets, in.xyz, in.k, qn, qe, f, idx, d2);  // the last cell's: near
      if (f == 0) continue;
      bool near = false, support = false;  // a neighbour within its reach; one in a large cluster
      // Neighbours come nearest first: beyond the largest reach none is near.
      for (int i = 0; i < f && !support && d2[i] <= max_reach2; ++i) {
        const std::size_t j = static_cast<std::size_t>(idx[i]);
        const double reach = in.reach != nullptr ? (*in.reach)[j] : in.gap_m;
        if (d2[i] > reach * reach) continue;
        near = true;
        support = in.supported[j] != 0;
      }
      if (!near) continue;
      if (!support) {
        ++counts.unsupported;
        continue;
      }
      double z = 0.0, var = 0.0;
      if (!s.solve(f, idx, d2, z, var)) continue;
      res.elevation.at(col, row) = static_cast<float>(z);
      double shared = 0.0;  // the cameras' error (SharedHeightError.hpp), unscaled
      if (in.shared_error != nullptr)
        shared = in.shared_error->cellVariance(*in.point_pairs, f, idx, s.w, qn, qe, z);
      res.sigma.at(col, row) =
          static_cast<float>(std::sqrt(res.sigma_scale * res.sigma_scale * var + shared));
      ++counts.kriged;
    }
  }
  counts.reuses = s.system.reuses();
  counts.factorisations = s.system.factorisations();
  return counts;
}

// The cells, rows split between threads (row r to thread r mod T). A cell's result does not depend on the
// cells solved before it (KrigingSystem's canonical order), so the DEM is the same for any T.
void krigeCells(const CellInputs& in, const DemGrid& grid, int threads_wanted, KrigingResult& res) {
  const int threads =
      std::clamp(cli::threadCount(threads_wanted), 1, std::max(1, std::min(grid.rows, kMaxKrigingThreads)));
  std::vector<RowCounts> counts(static_cast<std::size_t>(threads));
  cli::parallelFor(static_cast<std::size_t>(threads), threads, [&](std::size_t t) {
    counts[t] = krigeRows(in, grid, static_cast<int>(t), threads, res);
  });
  for (const RowCounts& c : counts) {
    res.cells_kriged += c.kriged;
    res.cells_unsupported += c.unsupported;
    res.factorisations += c.factorisations;
    res.factorisation_reuses += c.reuses;
  }
  res.threads = threads;
}

}  // namespace

double patchVarianceFactor(double m_px, double l_px) {
  const double m = std::max(1.0, m_px);
  if (!(l_px > 0.0)) return 1.0 / (m * m);
  const double g = segmentVariance(m, std::exp(-1.0 / l_px), std::exp(-m / l_px));
  return g * g;
}

// Per axis: 1 for the same segment, at_m for adjacent ones (centres m apart: the mean over the pixel pairs
// q * ((1 - q^m) / (1 - q))^2 / m^2, over g), at_m q^(d - m) beyond, linear in between (overlapping).
double patchCorrelation(double dx_px, double dy_px, double m_px, double l_px) {
  return patchCorrelation(dx_px, dy_px, m_px, l_px, l_px > 0.0 ? std::exp(-1.0 / l_px) : 0.0);
}

// Its exponentials by fastExp: evaluated for every new pair of neighbours of a cell.
double patchCorrelation(double dx_px, double dy_px, double m_px, double l_px, double q) {
  if (!(l_px > 0.0)) return dx_px == 0.0 && dy_px == 0.0 ? 1.0 : 0.0;
  const double m = std::max(1.0, m_px), qm = fastExp(-m / l_px);
  const double a = (1.0 - qm) / (1.0 - q);
  const double at_m = q * a * a / (m * m) / segmentVariance(m, q, qm);
  const bool far_x = dx_px >= m, far_y = dy_px >= m;
  if (far_x && far_y) return at_m * at_m * fastExp(-(dx_px + dy_px - 2.0 * m) / l_px);
  const auto axis = [&](double d, bool far) {
    return far ? at_m * fastExp(-(d - m) / l_px) : 1.0 + (at_m - 1.0) * d / m;
  };
  return axis(dx_px, far_x) * axis(dy_px, far_y);
}

DemGrid gridAround(const std::vector<DemPoint>& points, double cell_m) {
  if (points.empty() || !(cell_m > 0.0)) throw std::invalid_argument("gridAround: no points or cell <= 0");
  double n0 = 1e300, n1 = -1e300, e0 = 1e300, e1 = -1e300;
  for (const DemPoint& p : points) {
    n0 = std::min(n0, p.north_m);
    n1 = std::max(n1, p.north_m);
    e0 = std::min(e0, p.east_m);
    e1 = std::max(e1, p.east_m);
  }
  DemGrid g;
  g.cell_m = cell_m;
  g.east0_m = std::floor(e0 / cell_m) * cell_m - cell_m;
  g.north0_m = std::ceil(n1 / cell_m) * cell_m + cell_m;
  g.cols = static_cast<int>(std::ceil((e1 - g.east0_m) / cell_m)) + 1;
  g.rows = static_cast<int>(std::ceil((g.north0_m - n0) / cell_m)) + 1;
  g.values.assign(static_cast<std::size_t>(g.cols) * g.rows, g.nodata);
  return g;
}

KrigingResult krigeDem(const std::vector<DemPoint>& points, const DemGrid& grid, const KrigingOptions& o) {
  if (points.empty()) throw std::invalid_argument("kriging: no points");
  if (grid.cols <= 0 || grid.rows <= 0 || !(grid.cell_m > 0.0))
    throw std::invalid_argument("kriging: bad grid");
  if (o.cells != nullptr && o.cells->size() != static_cast<std::size_t>(grid.cols) * grid.rows)
    throw std::invalid_argument("kriging: the cell mask is not the grid's size");
  const int k = std::clamp(o.neighbours, 1, kMaxNeighbours);
  KrigingResult res;
  const double t0 = nowS();
  const PointCoordinates xyz = coordinatesOf(points);
  const KdTree2 tree(xyz.x, xyz.y);
  // The cells' neighbours near the last cell's (the k-d tree on ties).
  const PointBuckets buckets(xyz.x, xyz.y);
  const PointSpacing spacing = pointSpacing(tree, xyz, k);
  double gap = o.max_gap_m;
  const bool automatic_gap = !(gap > 0.0);
  if (automatic_gap) gap = std::max(kGapSpacings * spacing.to_8th_m, 2.0 * grid.cell_m);
  double max_lag = o.max_lag_m;
  if (!(max_lag > 0.0)) max_lag = automaticMaxLag(points, grid.cell_m, spacing.to_kth_m);
  res.max_gap_m = gap;
  res.min_cluster_points = static_cast<int>(std::min<std::size_t>(
      points.size(), static_cast<std::size_t>(std::clamp(o.min_cluster_points > 0 ? o.min_cluster_points : k,
                                                         1, kMaxNeighbours))));
  CorrelatedNoise correlated = correlatedNoiseOf(points, o);
  // Each point's noise sd less its pair-wide part, once (the pair terms need it for every pair of
  // neighbours).
  std::vector<double> local_sd;
  if (correlated.pair_sd != nullptr) {
    local_sd = localNoiseSd(points, *correlated.pair_sd);
    correlated.local_sd = &local_sd;
  }
  // The variogram, the signal variogram and the points' support do not depend on one another: made side
  // by side (each as it would be alone; the reaches are themselves split between threads).
  std::vector<float> reach;
  std::vector<uint8_t> supported;
  cli::parallelFor(3, 0, [&](std::size_t task) {
    if (task == 0 && o.model != nullptr) res.model = *o.model;
    if (task == 0 && o.model == nullptr) {
      res.experimental =
          experimentalVariogram(xyz.x, xyz.y, xyz.z, max_lag, 20, 2000000, 1, {}, false, &tree);
      res.model = fitVariogram(res.experimental);
    }
    if (task == 1 && correlated.on()) {
      res.signal_experimental = experimentalVariogram(
          xyz.x, xyz.y, xyz.z, max_lag, 20, 2000000, 1,
          [&](std::size_t i, std::size_t j) { return correlated.pairNoise(points, i, j); }, true, &tree);
      res.signal_model = fitVariogram(res.signal_experimental);
    }
    if (task == 2) {
      if (automatic_gap && o.local_reach) reach = pointReaches(tree, buckets, xyz, gap);
      supported = supportedPoints(xyz, gap, res.min_cluster_points, res.isolated_points);
    }
  });
  correlated.signal = res.signal_model;
  // A point the support rule refuses supports no cell: its reach is the cloud's (the cells it leaves empty).
  for (std::size_t i = 0; i < reach.size(); ++i)
    if (!supported[i]) reach[i] = static_cast<float>(gap);
  if (!reach.empty()) res.max_local_gap_m = *std::max_element(reach.begin(), reach.end());
  const double t1 = nowS();
  res.variogram_seconds = t1 - t0;

  res.elevation = grid;
  res.elevation.values.assign(static_cast<std::size_t>(grid.cols) * grid.rows, grid.nodata);
  res.sigma = res.elevation;
  const bool shared =
      o.shared_error != nullptr && o.point_pairs != nullptr && o.point_pairs->size() == points.size();
  const CellInputs cells{points,
                         xyz,
                         tree,
                         buckets,
                         supported,
                         reach.empty() ? nullptr : &reach,
                         k,
                         gap,
                         reach.empty() ? gap : res.max_local_gap_m,
                         res.model,
                         o.use_point_sigma,
                         correlated,
                         o.point_pairs,
                         shared ? o.shared_error : nullptr,
                         o.cells};
  // Not with correlated point errors: that sigma is a model of its own (the calibrated point sigmas, their
  // correlation and the signal variogram), and a point's leave-one-out error would need its covariance
  // with its neighbours' errors, which the independent-noise ratio leaves out.
  if (!correlated.on()) res.sigma_scale = calibrateSigmaScale(cells, xyz);
  krigeCells(cells, grid, o.threads, res);
  res.kriging_seconds = nowS() - t1;
  return res;
}

}  // namespace areomap::dem
