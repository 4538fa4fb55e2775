// How a point cloud's height errors are correlated on the ground (docs/benchmarks-history.md "DEM
// accuracy and DEM sigma"): point_error_check DATASET POINTS.ply [--range LO,HI]
// Every point of POINTS.ply (site frame, products' points.ply) between LO and HI metres from the site origin
// (default 2,5) against DATASET/truth/dem.tif, after the common datum rotation of the adjusted models beside
// it (POINTS.ply's folder/models; TruthDatum.hpp) is removed; errors over 5 cm are left out (mismatches,
// occlusion edges).
// Prints the median |error|, the median |error| / sigma (0.674 for an honest Gaussian sigma), and the
// correlation of two points' errors by their distance on the ground, for points of one pair and of two
// different pairs (LineId.hpp). What a DEM cell's bin and the kriging's neighbourhood can average down
// depends on it. With --bins CELL the points are also binned per pair on a CELL-metre grid (bins of >= 3
// points): the correlation of one pair's bin errors with its neighbouring bins' (from truth), the same for
// the field of two pairs' bin differences (what the data alone can measure), and the correlation of two
// pairs' errors in one bin (from the RMS of their difference against that of their errors).
#include <algorithm>
#include <map>
#include <tuple>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <unordered_map>
#include <vector>

#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/DemRaster.hpp"
#include "ground/dense/LineId.hpp"
#include "ground/dense/Triangulation.hpp"
#include "ground/ortho/Orthoimage.hpp"
#include "tests/ground/products/TruthDatum.hpp"

using namespace areomap;

namespace {

struct PointError {
  double north, east, error, sigma;
  int64_t pair;
};

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// --bins: see the file's comment.
void binCorrelations(const std::vector<PointError>& pts, double bin_m) {
  struct Acc {
    double n = 0, z = 0, x = 0, y = 0;
  };
  using Key = std::tuple<long long, long long, int64_t>;  // row, column, pair
  std::map<Key, Acc> bins;
  for (const PointError& p : pts) {
    Acc& a = bins[{static_cast<long long>(std::floor(p.north / bin_m)),
                   static_cast<long long>(std::floor(p.east / bin_m)), p.pair}];
    a.n += 1;
    a.z += p.error;  // the error's mean is the bin mean's error (the truth at each point)
    a.x += p.north;
    a.y += p.east;
  }
  std::map<Key, double> err;
  std::map<std::pair<long long, long long>, std::vector<std::pair<int64_t, double>>> by_cell;
  for (const auto& [k, a] : bins) {
    if (a.n < 3) continue;
    err[k] = a.z / a.n;
    by_cell[{std::get<0>(k), std::get<1>(k)}].push_back({std::get<2>(k), a.z / a.n});
  }
  using DKey = std::tuple<long long, long long, int64_t, int64_t>;
  std::map<DKey, double> diff;
  double s_e2 = 0.0, s_d2 = 0.0;
  long long n_e = 0;
  for (const auto& [c, v] : by_cell) {
    for (std::size_t i = 0; i < v.size(); ++i) {
      for (std::size_t j = i + 1; j < v.size(); ++j) {
        diff[{c.first, c.second, std::min(v[i].first, v[j].first), std::max(v[i].first, v[j].first)}] =
            v[i].first < v[j].first ? v[i].second - v[j].second : v[j].second - v[i].second;
        s_e2 += v[i].second * v[i].second + v[j].second * v[j].second;
        n_e += 2;
      }
    }
  }
  if (err.empty() || diff.empty()) {
    std::printf("bins of %.3f m: no bin seen by two pairs\n", bin_m);
    return;
  }
  double ve = 0.0, vd = 0.0;
  for (const auto& [k, e] : err) ve += e * e;
  ve /= static_cast<double>(err.size());
  for (const auto& [k, d] : diff) vd += d * d;
  vd /= static_cast<double>(diff.size());
  s_d2 = vd;
  const double rms_e_overlap = std::sqrt(s_e2 / static_cast<double>(n_e));
  std::printf(
      "\nbins of %.3f m: %zu one-pair bins (RMS error %.5f m), %zu two-pair bins: RMS error %.5f m, RMS "
      "difference %.5f m -> the two pairs' errors correlated by %.2f\n",
      bin_m, err.size(), std::sqrt(ve), diff.size(), rms_e_overlap, std::sqrt(s_d2),
      1.0 - s_d2 / (2.0 * rms_e_overlap * rms_e_overlap));
  std::printf(
      "| lag (cells) | one pair's bin errors (truth) | two pairs' differences (data) |\n|---|---|---|\n");
  const int lags[][2] = {{0, 1}, {1, 0}, {1, 1}, {0, 2}, {2, 0}, {0, 3}, {3, 0}, {0, 5}, {5, 0}};
  for (const auto& l : lags) {
    double se = 0.0, sd = 0.0;
    long long ne = 0, nd = 0;
    for (const auto& [k, e] : err) {
      const auto it = err.find({std::get<0>(k) + l[0], std::get<1>(k) + l[1], std::get<2>(k)});
      if (it == err.end()) continue;
      se += e * it->second;
      ++ne;
    }
    for (const auto& [k, d] : diff) {
      const auto it =
          diff.find({std::get<0>(k) + l[0], std::get<1>(k) + l[1], std::get<2>(k), std::get<3>(k)});
      if (it == diff.end()) continue;
      sd += d * it->second;
      ++nd;
    }
    std::printf("| (%d, %d) | %.3f (%lld) | %.3f (%lld) |\n", l[0], l[1], ne ? se / ne / ve : 0.0, ne,
                nd ? sd / nd / vd : 0.0, nd);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: point_error_check DATASET POINTS.ply [--range LO,HI]\n");
    return 2;
  }
  double lo = 2.0, hi = 5.0, bin_m = 0.0;
  for (int i = 3; i + 1 < argc; ++i) {
    if (std::string(argv[i]) == "--range" && std::sscanf(argv[i + 1], "%lf,%lf", &lo, &hi) != 2) {
      std::fprintf(stderr, "--range: expected LO,HI\n");
      return 2;
    }
    if (std::string(argv[i]) == "--bins" && !(std::sscanf(argv[i + 1], "%lf", &bin_m) == 1 && bin_m > 0.0)) {
      std::fprintf(stderr, "--bins: expected a cell size in metres\n");
      return 2;
    }
  }
  try {
    const std::string root = argv[1], ply = argv[2];
    const DemGrid truth = readDemGeoTiff(root + "/truth/dem.tif");
    const test::TruthDatum datum =
        test::truthDatum(readDataset(root), root, std::filesystem::path(ply).parent_path().string());
    std::printf("datum rotation removed %.3f mrad (%zu adjusted models)\n", 1e3 * datum.angleRad(),
                datum.adjusted_models);
    std::vector<PointError> pts;
    for (const dense::CloudPoint& p : dense::readPly(ply)) {
      const Vec3 q = datum.align(p.site_m);
      const double r = std::hypot(q.x(), q.y());
      double z = 0.0;
      if (r < lo || r > hi || !ortho::demElevation(truth, q.x(), q.y(), z)) continue;
      const double e = -q.z() - z;
      if (std::fabs(e) > 0.05 || !(p.sigmaHeight_m() > 0.0)) continue;
      pts.push_back({q.x(), q.y(), e, p.sigmaHeight_m(), dense::linePair(p.line)});
    }
    if (pts.size() < 100) {
      std::fprintf(stderr, "point_error_check: only %zu points in %.1f..%.1f m\n", pts.size(), lo, hi);
      return 1;
    }
    std::vector<double> abs_e, ratio;
    double mean = 0.0;
    for (const PointError& p : pts) {
      abs_e.push_back(std::fabs(p.error));
      ratio.push_back(std::fabs(p.error) / p.sigma);
      mean += p.error;
    }
    mean /= static_cast<double>(pts.size());
    double var = 0.0;
    for (const PointError& p : pts) var += (p.error - mean) * (p.error - mean);
    var /= static_cast<double>(pts.size());
    std::printf(
        "%zu points at %.1f-%.1f m: mean error %+.5f m, median |error| %.5f m, median |error|/sigma %.3f "
        "(0.674: honest)\n",
        pts.size(), lo, hi, mean, median(abs_e), median(ratio));
    // Pairs of points in rings [0.8 d, 1.25 d] about every 7th point, through a 1 cm bucket grid.
    constexpr double kBucketM = 0.01;
    std::unordered_map<long long, std::vector<int>> grid;
    const auto key = [](long long i, long long j) { return i * 1000003LL + j; };
    for (int i = 0; i < static_cast<int>(pts.size()); ++i) {
      grid[key(static_cast<long long>(std::floor(pts[i].north / kBucketM)),
               static_cast<long long>(std::floor(pts[i].east / kBucketM)))]
          .push_back(i);
    }
    std::printf(
        "| distance | correlation, one pair | pairs of points | two pairs | pairs of points |\n"
        "|---|---|---|---|---|\n");
    for (double d : {0.005, 0.01, 0.02, 0.03, 0.05, 0.08, 0.12, 0.2, 0.3, 0.5}) {
      double same = 0.0, other = 0.0;
      long long n_same = 0, n_other = 0;
      const int reach = static_cast<int>(std::ceil(d * 1.25 / kBucketM));
      const int stride = std::max(1, reach / 3);
      for (int i = 0; i < static_cast<int>(pts.size()); i += 7) {
        const long long ci = static_cast<long long>(std::floor(pts[i].north / kBucketM));
        const long long cj = static_cast<long long>(std::floor(pts[i].east / kBucketM));
        for (int di = -reach; di <= reach; di += stride) {
          for (int dj = -reach; dj <= reach; dj += stride) {
            const auto it = grid.find(key(ci + di, cj + dj));
            if (it == grid.end()) continue;
            for (int k : it->second) {
              const double dist = std::hypot(pts[k].north - pts[i].north, pts[k].east - pts[i].east);
              if (dist < 0.8 * d || dist > 1.25 * d) continue;
              const double product = (pts[i].error - mean) * (pts[k].error - mean);
              if (pts[k].pair == pts[i].pair) {
                same += product;
                ++n_same;
              } else {
                other += product;
                ++n_other;
              }
            }
          }
        }
      }
      std::printf("| %.3f m | %.3f | %lld | %.3f | %lld |\n", d, n_same ? same / n_same / var : 0.0, n_same,
                  n_other ? other / n_other / var : 0.0, n_other);
    }
    if (bin_m > 0.0) binCorrelations(pts, bin_m);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "point_error_check: %s\n", e.what());
    return 1;
  }
  return 0;
}
