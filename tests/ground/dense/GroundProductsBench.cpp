// Benchmark of the ground products' algorithms, side by side in one run:
//  - dense matching on Middlebury Cones and on a synthetic 1024x1024 pair, areomap vs OpenCV StereoSGBM:
//    time, bad-pixel rate (> 1 px) and density;
//  - ordinary kriging of 1e4 and 1e5 points onto 1e6 cells: time and RMSE against the synthetic truth.
// Usage: ground_products_bench [--quick] [--kriging-only] [--export DIR]   (--quick: 2.5e5 cells instead of
// 1e6; --export: the kriging points and fitted models for tests/ground/dem/gstat_benchmark.sh)
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ground/dem/Kriging.hpp"
#include "ground/dense/DenseMatcher.hpp"
#include "ground/dense/DisparityScore.hpp"
#include "tests/support/TestData.hpp"

using namespace areomap;

namespace {

double nowS() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

cv::Mat sgbm(const cv::Mat& l, const cv::Mat& r, int num_disp) {
  const int b = 5;
  cv::Ptr<cv::StereoSGBM> m = cv::StereoSGBM::create(0, num_disp, b, 8 * b * b, 32 * b * b, 1, 63, 10, 100, 2,
                                                     cv::StereoSGBM::MODE_HH);
  cv::Mat d16, out;
  m->compute(l, r, d16);
  d16.convertTo(out, CV_32F, 1.0 / 16.0);
  out.setTo(NAN, d16 < 0);
  return out;
}

// RMS error (px) of the matches within 1 px of the truth: the sub-pixel part.
double goodRms(const cv::Mat& disparity, const cv::Mat& truth, const cv::Mat& mask) {
  double s2 = 0.0;
  long long n = 0;
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) {
      const float t = truth.at<float>(y, x), d = disparity.at<float>(y, x);
      if (!(t > 0.0f) || std::isnan(d) || (!mask.empty() && mask.at<uint8_t>(y, x) == 0)) continue;
      const double e = d - t;
      if (std::fabs(e) > 1.0) continue;
      s2 += e * e;
      ++n;
    }
  }
  return n > 0 ? std::sqrt(s2 / static_cast<double>(n)) : 0.0;
}

void compare(const char* name, const cv::Mat& l, const cv::Mat& r, const cv::Mat& truth, const cv::Mat& mask,
             int num_disp) {
  double t0 = nowS();
  const cv::Mat s = sgbm(l, r, num_disp);
  double t1 = nowS();
  dense::DenseOptions o;
  o.max_disparity_px = num_disp - 1;
  const dense::DenseResult a = dense::matchRectified(l, r, o);
  double t2 = nowS();
  o.refine_subpixel = true;
  const dense::DenseResult b = dense::matchRectified(l, r, o);
  double t3 = nowS();
  const dense::DisparityScore ss = dense::scoreDisparity(s, truth, mask);
  const dense::DisparityScore sa = dense::scoreDisparity(a.disparity, truth, mask);
  const dense::DisparityScore sb = dense::scoreDisparity(b.disparity, truth, mask);
  std::printf("| %s | StereoSGBM (block 5, MODE_HH) | %.3f | %.2f | %.2f | %.3f |\n", name, t1 - t0,
              100 * ss.badRate(), 100 * ss.density(), goodRms(s, truth, mask));
  std::printf("| %s | areomap coarse-to-fine census SGM | %.3f | %.2f | %.2f | %.3f |\n", name, t2 - t1,
              100 * sa.badRate(), 100 * sa.density(), goodRms(a.disparity, truth, mask));
  std::printf("| %s | areomap, --subpixel lsm | %.3f | %.2f | %.2f | %.3f |\n", name, t3 - t2,
              100 * sb.badRate(), 100 * sb.density(), goodRms(b.disparity, truth, mask));
}

// A 1024x1024 random-texture pair with a disparity field: a ground ramp (rows map to range) with raised
// blocks; the right image is rendered with a z-buffer along rows.
void synthetic1024(cv::Mat& l, cv::Mat& r, cv::Mat& truth) {
  const int n = 1024;
  cv::RNG rng(3);
  cv::Mat tex(n, n + 200, CV_8UC1);
  rng.fill(tex, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(tex, tex, cv::Size(5, 5), 1.2);
  truth.create(n, n, CV_32FC1);
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      float d = 4.0f + 100.0f * static_cast<float>(y) / n;
      for (int k = 0; k < 12; ++k) {
        const int bx = 60 + 80 * k, by = 100 + (k * 373) % 800;
        if (x > bx && x < bx + 50 && y > by && y < by + 60) d += 15.0f;
      }
      truth.at<float>(y, x) = std::round(d);
    }
  }
  l.create(n, n, CV_8UC1);
  r.create(n, n, CV_8UC1);
  for (int y = 0; y < n; ++y) {
    std::vector<float> best(n, -1.0f);
    for (int x = 0; x < n; ++x) {
      const float d = truth.at<float>(y, x);
      const int xr = x - static_cast<int>(d);
      if (xr >= 0 && d > best[xr]) best[xr] = d;
      l.at<uint8_t>(y, x) = tex.at<uint8_t>(y, x + 100);
    }
    for (int xr = 0; xr < n; ++xr) {
      const int xl = xr + static_cast<int>(best[xr] < 0 ? truth.at<float>(y, std::min(xr, n - 1)) : best[xr]);
      r.at<uint8_t>(y, xr) = tex.at<uint8_t>(y, std::min(xl, n + 99) + 100 > n + 199 ? n + 199 : xl + 100);
    }
  }
}

double field(double x, double y) {
  return 0.4 * std::sin(x / 7.0) * std::cos(y / 11.0) + 0.2 * std::sin((x + y) / 5.0) + 0.05 * std::cos(x / 2.3);
}

// With `export_dir`, the points and our fitted model are written for tests/ground/dem/gstat_benchmark.sh
// (R's gstat kriges the same points with the same model and neighbourhood size).
void kriging(int n_points, int side, int k, const std::string& export_dir) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0.0, 100.0);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<dem::DemPoint> pts(static_cast<std::size_t>(n_points));
  for (dem::DemPoint& p : pts) {
    p.north_m = u(rng);
    p.east_m = u(rng);
    p.elevation_m = field(p.north_m, p.east_m) + noise(rng);
    p.sigma_m = 0.01;
  }
  DemGrid g;
  g.cell_m = 100.0 / side;
  g.east0_m = 0.0;
  g.north0_m = 100.0;
  g.cols = side;
  g.rows = side;
  dem::KrigingOptions o;
  o.neighbours = k;
  o.max_gap_m = 100.0;
  const dem::KrigingResult r = dem::krigeDem(pts, g, o);  // one thread per core
  // The same on one thread (gstat uses one): the result is identical (KrigingSystem test), only the time.
  dem::KrigingOptions o1 = o;
  o1.threads = 1;
  const double one_thread_s = dem::krigeDem(pts, g, o1).kriging_seconds;
  double ss = 0.0;
  long long n = 0;
  for (int row = 0; row < side; ++row) {
    for (int col = 0; col < side; ++col) {
      const float z = r.elevation.at(col, row);
      if (z == g.nodata) continue;
      const double e = z - field(g.northOfRow(row), g.eastOfCol(col));
      ss += e * e;
      ++n;
    }
  }
  std::printf("| %d | %d x %d | %d | %s | %.2f | %.2f (%d threads) | %.2f | %.4f |\n", n_points, side, side, k,
              dem::variogramName(r.model.kind), r.variogram_seconds, r.kriging_seconds, r.threads, one_thread_s,
              std::sqrt(ss / n));
  if (export_dir.empty()) return;
  const std::string stem = export_dir + "/points_" + std::to_string(n_points);
  if (FILE* f = std::fopen((stem + ".csv").c_str(), "w")) {
    std::fprintf(f, "east,north,z\n");
    for (const dem::DemPoint& p : pts) std::fprintf(f, "%.6f,%.6f,%.6f\n", p.east_m, p.north_m, p.elevation_m);
    std::fclose(f);
  }
  if (FILE* f = std::fopen((stem + "_model.csv").c_str(), "w")) {
    std::fprintf(f, "kind,nugget_m2,partial_sill_m2,range_m,side,k,areomap_kriging_s,areomap_threads,"
                    "areomap_kriging_1thread_s,areomap_variogram_s,areomap_rmse_m\n");
    std::fprintf(f, "%s,%.9g,%.9g,%.9g,%d,%d,%.3f,%d,%.3f,%.3f,%.6f\n", dem::variogramName(r.model.kind),
                 r.model.nugget_m2, r.model.partial_sill_m2, r.model.range_m, side, k, r.kriging_seconds, r.threads,
                 one_thread_s, r.variogram_seconds, std::sqrt(ss / n));
    std::fclose(f);
  }
}

}  // namespace

void matching();  // dense matching side by side (below)

int main(int argc, char** argv) {
  bool quick = false, kriging_only = false;
  std::string export_dir;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
    } else if (std::strcmp(argv[i], "--kriging-only") == 0) {
      kriging_only = true;
    } else if (std::strcmp(argv[i], "--export") == 0 && i + 1 < argc) {
      export_dir = argv[++i];
    } else {
      std::fprintf(stderr, "usage: ground_products_bench [--quick] [--kriging-only] [--export DIR]\n");
      return 2;
    }
  }
  if (!kriging_only) matching();
  std::printf("\n## Ordinary kriging (100 x 100 m random field, 1 cm noise)\n\n");
  std::printf("| points | cells | k | model | variogram s | kriging s | kriging s, 1 thread | RMSE m |\n"
              "|---|---|---|---|---|---|---|---|\n");
  const int side = quick ? 500 : 1000;
  kriging(10000, side, 16, export_dir);
  kriging(100000, side, 16, export_dir);
  return 0;
}

void matching() {
  std::printf("## Dense matching (bad = error > 1 px over evaluated pixels with a disparity)\n\n");
  std::printf(
      "| pair | matcher | seconds | bad %% | density %% | RMS within 1 px |\n|---|---|---|---|---|---|\n");
  const std::string dir = test::sharedDataDir() + "/middlebury-cones/";
  const cv::Mat cl = cv::imread(dir + "left.tif", cv::IMREAD_GRAYSCALE);
  const cv::Mat cr = cv::imread(dir + "right.tif", cv::IMREAD_GRAYSCALE);
  const cv::Mat ct = cv::imread(dir + "disp_left.tif", cv::IMREAD_UNCHANGED);
  const cv::Mat co = cv::imread(dir + "occl.png", cv::IMREAD_GRAYSCALE);
  if (!cl.empty() && !cr.empty() && !ct.empty() && !co.empty()) {
    compare("Cones 450x375 (non-occluded)", cl, cr, ct, co > 0, 64);
  } else {
    std::printf("| Cones | (data missing under %s) | | | | |\n", dir.c_str());
  }
  cv::Mat l, r, t;
  synthetic1024(l, r, t);
  cv::Mat mask(t.size(), CV_8UC1, cv::Scalar(255));
  mask(cv::Rect(0, 0, 130, t.rows)).setTo(0);  // no right counterpart
  compare("synthetic 1024x1024, d 4..119", l, r, t, mask, 128);
}
