#include "ground/dem/Kriging.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include <Eigen/Dense>

#include "ground/dem/KdTree.hpp"

namespace areomap::dem {

namespace {

double nowS() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

constexpr int kGapSample = 2000;  // points sampled for the automatic gap limit
constexpr double kLagPerNeighbourhood = 3.0;  // automatic variogram extent, in neighbourhood radii

using KMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxNeighbours + 1, kMaxNeighbours + 1>;
using KVec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxNeighbours + 1, 1>;

constexpr int kCalibrationSample = 400;   // points of the leave-one-out sigma calibration
constexpr int kMinCalibrationPoints = 30;

// One ordinary-kriging solve (covariance form with the Lagrange row) for a query whose neighbours and
// their squared distances are given.
struct Solver {
  const std::vector<DemPoint>& points;
  const VariogramModel& m;
  bool use_point_sigma;

  double noise(const DemPoint& p) const {
    return use_point_sigma ? std::max(m.nugget_m2, p.sigma_m * p.sigma_m) : m.nugget_m2;
  }

  bool solve(int f, const int32_t* idx, const double* d2, double& z, double& var) const {
    const double psill = std::max(m.partial_sill_m2, 1e-12);
    const double jitter = 1e-9 * (psill + m.nugget_m2);
    KMat a(f + 1, f + 1);
    KVec b(f + 1);
    for (int i = 0; i < f; ++i) {
      const DemPoint& pi = points[static_cast<std::size_t>(idx[i])];
      for (int j = i + 1; j < f; ++j) {
        const DemPoint& pj = points[static_cast<std::size_t>(idx[j])];
        const double c = psill * m.correlation(std::hypot(pi.north_m - pj.north_m, pi.east_m - pj.east_m));
        a(i, j) = c;
        a(j, i) = c;
      }
      a(i, i) = psill + noise(pi) + jitter;
      a(i, f) = 1.0;
      a(f, i) = 1.0;
      b(i) = psill * m.correlation(std::sqrt(d2[i]));
    }
    a(f, f) = 0.0;
    b(f) = 1.0;
    const KVec sol = a.partialPivLu().solve(b);
    z = 0.0;
    double lc = 0.0;
    for (int i = 0; i < f; ++i) {
      z += sol(i) * points[static_cast<std::size_t>(idx[i])].elevation_m;
      lc += sol(i) * b(i);
    }
    var = std::max(0.0, psill - lc - sol(f));
    return std::isfinite(z) && std::isfinite(var);
  }
};

}  // namespace

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
  if (grid.cols <= 0 || grid.rows <= 0 || !(grid.cell_m > 0.0)) throw std::invalid_argument("kriging: bad grid");
  const int k = std::clamp(o.neighbours, 1, kMaxNeighbours);
  KrigingResult res;
  const double t0 = nowS();
  std::vector<double> xs(points.size()), ys(points.size()), zs(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    xs[i] = points[i].north_m;
    ys[i] = points[i].east_m;
    zs[i] = points[i].elevation_m;
  }
  const KdTree2 tree(xs, ys);
  // Point spacing: the median distance to the 8th and to the k-th neighbour over a sample of points.
  double spacing8 = 0.0, spacing_k = 0.0;
  {
    std::vector<double> s8, sk;
    const std::size_t step = std::max<std::size_t>(1, points.size() / kGapSample);
    int32_t idx[kMaxNeighbours];
    double d2[kMaxNeighbours];
    for (std::size_t i = 0; i < points.size(); i += step) {
      const int f = tree.nearest(xs[i], ys[i], k, idx, d2);
      if (f > 0) {
        s8.push_back(std::sqrt(d2[std::min(f, 8) - 1]));
        sk.push_back(std::sqrt(d2[f - 1]));
      }
    }
    std::nth_element(s8.begin(), s8.begin() + s8.size() / 2, s8.end());
    std::nth_element(sk.begin(), sk.begin() + sk.size() / 2, sk.end());
    spacing8 = s8[s8.size() / 2];
    spacing_k = sk[sk.size() / 2];
  }
  double gap = o.max_gap_m;
  if (!(gap > 0.0)) gap = std::max(3.0 * spacing8, 2.0 * grid.cell_m);
  double max_lag = o.max_lag_m;
  if (!(max_lag > 0.0)) {
    const DemGrid box = gridAround(points, grid.cell_m);
    // The variogram matters at the scale of the kriging neighbourhoods: fit it there.
    max_lag = std::min(std::hypot(box.cols * box.cell_m, box.rows * box.cell_m) / 3.0,
                       kLagPerNeighbourhood * std::max(spacing_k, grid.cell_m));
  }
  if (o.model != nullptr) {
    res.model = *o.model;
  } else {
    res.experimental = experimentalVariogram(xs, ys, zs, max_lag);
    res.model = fitVariogram(res.experimental);
  }
  res.max_gap_m = gap;
  const double t1 = nowS();
  res.variogram_seconds = t1 - t0;

  res.elevation = grid;
  res.elevation.values.assign(static_cast<std::size_t>(grid.cols) * grid.rows, grid.nodata);
  res.sigma = res.elevation;
  const Solver solver{points, res.model, o.use_point_sigma};
  int32_t idx[kMaxNeighbours + 1];
  double d2[kMaxNeighbours + 1];
  // Sigma calibration by leave-one-out cross-validation on a sample of points: the kriging variance plus
  // the point's noise should explain the squared LOO error on average; the ratio scales every sigma.
  {
    double sum_ratio = 0.0;
    long long used = 0;
    const std::size_t step = std::max<std::size_t>(1, points.size() / kCalibrationSample);
    for (std::size_t i = 0; i < points.size(); i += step) {
      const int f = tree.nearest(xs[i], ys[i], k + 1, idx, d2);
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
    res.sigma_scale = used >= kMinCalibrationPoints ? std::sqrt(sum_ratio / static_cast<double>(used)) : 1.0;
  }
  for (int row = 0; row < grid.rows; ++row) {
    const double qn = grid.northOfRow(row);
    for (int col = 0; col < grid.cols; ++col) {
      const double qe = grid.eastOfCol(col);
      const int f = tree.nearest(qn, qe, k, idx, d2);
      if (f == 0 || d2[0] > gap * gap) continue;
      double z = 0.0, var = 0.0;
      if (!solver.solve(f, idx, d2, z, var)) continue;
      res.elevation.at(col, row) = static_cast<float>(z);
      res.sigma.at(col, row) = static_cast<float>(res.sigma_scale * std::sqrt(var));
      ++res.cells_kriged;
    }
  }
  res.kriging_seconds = nowS() - t1;
  return res;
}

}  // namespace areomap::dem
