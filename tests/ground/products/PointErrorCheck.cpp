// How a point cloud's height errors are correlated on the ground (BENCHMARKS.md "DEM accuracy and DEM
// sigma"): point_error_check DATASET POINTS.ply [--range LO,HI]
// Every point of POINTS.ply (site frame, products' points.ply) between LO and HI metres from the site origin
// (default 2,5) against DATASET/truth/dem.tif; errors over 5 cm are left out (mismatches, occlusion edges).
// Prints the median |error|, the median |error| / sigma (0.674 for an honest Gaussian sigma), and the
// correlation of two points' errors by their distance on the ground, for points of one pair and of two
// different pairs (LineId.hpp). What a DEM cell's bin and the kriging's neighbourhood can average down
// depends on it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <unordered_map>
#include <vector>

#include "ground/dataset/DemRaster.hpp"
#include "ground/dense/LineId.hpp"
#include "ground/dense/Triangulation.hpp"
#include "ground/ortho/Orthoimage.hpp"

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

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: point_error_check DATASET POINTS.ply [--range LO,HI]\n");
    return 2;
  }
  double lo = 2.0, hi = 5.0;
  for (int i = 3; i + 1 < argc; ++i) {
    if (std::string(argv[i]) == "--range" && std::sscanf(argv[i + 1], "%lf,%lf", &lo, &hi) != 2) {
      std::fprintf(stderr, "--range: expected LO,HI\n");
      return 2;
    }
  }
  try {
    const DemGrid truth = readDemGeoTiff(std::string(argv[1]) + "/truth/dem.tif");
    std::vector<PointError> pts;
    for (const dense::CloudPoint& p : dense::readPly(argv[2])) {
      const double r = std::hypot(p.site_m.x(), p.site_m.y());
      double z = 0.0;
      if (r < lo || r > hi || !ortho::demElevation(truth, p.site_m.x(), p.site_m.y(), z)) continue;
      const double e = -p.site_m.z() - z;
      if (std::fabs(e) > 0.05 || !(p.sigmaHeight_m() > 0.0)) continue;
      pts.push_back({p.site_m.x(), p.site_m.y(), e, p.sigmaHeight_m(), dense::linePair(p.line)});
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
  } catch (const std::exception& e) {
    std::fprintf(stderr, "point_error_check: %s\n", e.what());
    return 1;
  }
  return 0;
}
