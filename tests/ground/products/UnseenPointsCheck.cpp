// What the dense points that fall in cells no true camera sees are (docs/products.md "Seen and unseen
// cells"): unseen_points_check DATASET PRODUCTS [--range M]
// DATASET: a synthetic dataset (images, truth/dem.tif, truth/models); PRODUCTS: a products folder
// (points.ply, dem.tif). Every point of points.ply whose DEM cell is unseen in truth (products::
// truthCellsSeen), and as a control every 16th point of a seen cell, after the datum rotation
// (TruthDatum.hpp): per range band the points, their height error against the true DEM over their sigma,
// and how the ray from the left camera of their pair (LineId.hpp) to them clears the true surface before
// them: through it (the camera could not see the point: a wrong match), grazing it (within the point's
// own sigma), or clear over it (a point on a free line of sight, moved along it by its range error).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/DemRaster.hpp"
#include "ground/dense/LineId.hpp"
#include "ground/dense/Triangulation.hpp"
#include "ground/ortho/Orthoimage.hpp"
#include "ground/products/TruthSeen.hpp"
#include "tests/ground/products/TruthDatum.hpp"

using namespace areomap;

namespace {

constexpr int kBands = 5;
constexpr double kEdges[kBands + 1] = {0, 5, 10, 15, 20, 1e9};

struct Tally {
  long long points = 0;
  long long high = 0, low = 0, within = 0;             // height error > 3 sigma, < -3 sigma, else
  long long through = 0, grazing = 0, clear = 0;       // the left camera's ray against the true surface
  long long through_high = 0, clear_high = 0;
  std::vector<double> dz, dz_over_sigma, ray_depth;
};

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// The lowest clearance (metres, ray height less the true ground) of the segment from `from` to `to`
// (truth's frame, Z down) over the true surface, from 0.3 m after `from` to `stop_m` before `to`
// (horizontally), sampled every truth cell.
double lowestClearance(const DemGrid& truth, const Vec3& from, const Vec3& to, double stop_m) {
  const double horizontal = (to - from).head<2>().norm();
  double lowest = 1e9;
  for (double s = 0.3; s < horizontal - stop_m; s += truth.cell_m) {
    const Vec3 x = from + (to - from) * (s / horizontal);
    double z = 0.0;
    if (!ortho::demElevation(truth, x.x(), x.y(), z)) continue;
    lowest = std::min(lowest, -x.z() - z);
  }
  return lowest;
}

void print(const char* name, const Tally (&t)[kBands]) {
  std::printf("%s\n  band      points   dz>3s  dz<-3s  |dz|<=3s  med dz(m) med dz/s  ray through grazing clear  "
              "(of dz>3s: through clear)  med depth(m)\n",
              name);
  for (int b = 0; b < kBands; ++b) {
    const Tally& a = t[b];
    if (a.points == 0) continue;
    const double n = static_cast<double>(a.points);
    std::printf("  %2.0f-%-4.0f %8lld  %5.1f%%  %5.1f%%  %6.1f%%  %8.3f  %7.2f  %6.1f%% %6.1f%% %6.1f%%  (%5.1f%% %5.1f%%)  %8.3f\n",
                kEdges[b], kEdges[b + 1] > 1e8 ? 99.0 : kEdges[b + 1], a.points, 100 * a.high / n, 100 * a.low / n,
                100 * a.within / n, median(a.dz), median(a.dz_over_sigma), 100 * a.through / n, 100 * a.grazing / n,
                100 * a.clear / n, a.high ? 100.0 * a.through_high / a.high : 0.0,
                a.high ? 100.0 * a.clear_high / a.high : 0.0, median(a.ray_depth));
  }
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (args.size() < 2) {
    std::fprintf(stderr, "usage: unseen_points_check DATASET PRODUCTS [--range M]\n");
    return 2;
  }
  const std::string& root = args[0];
  const std::string& out = args[1];
  const auto range_arg = std::find(args.begin(), args.end(), std::string("--range"));
  const double range_m = range_arg != args.end() && range_arg + 1 != args.end() ? std::atof((range_arg + 1)->c_str()) : 60.0;
  const Dataset ds = readDataset(root);
  const test::TruthDatum datum = test::truthDatum(ds, root, out);
  const DemGrid truth = readDemGeoTiff(root + "/truth/dem.tif"), dem = readDemGeoTiff(out + "/dem.tif");
  std::vector<cv::Mat> images;
  std::map<int64_t, std::size_t> left_of_pair;  // pair id -> index of its left image
  for (const Pair& p : ds.pairs) {
    left_of_pair[p.id] = images.size();
    for (const ImageRef* ref : {&p.left, p.right ? &*p.right : nullptr})
      if (ref != nullptr) images.push_back(cv::imread(ref->image_path, cv::IMREAD_GRAYSCALE));
  }
  std::vector<CameraModel> models = datum.truth_models;
  for (std::size_t k = 0; k < models.size() && k < images.size(); ++k) {
    models[k].width = images[k].cols;
    models[k].height = images[k].rows;
  }
  products::TruthFrame frame;
  frame.gimbal = datum.centre;
  frame.r = datum.rotation;
  const std::vector<uint8_t> seen = products::truthCellsSeen(dem, truth, images, models, frame);
  const std::vector<dense::CloudPoint> pts = dense::readPly(out + "/points.ply");
  Tally unseen[kBands], control[kBands];
  std::map<int64_t, long long> unseen_by_pair;
  long long counted = 0;
  for (std::size_t k = 0; k < pts.size(); ++k) {
    const dense::CloudPoint& p = pts[k];
    const Vec3& x = p.site_m;
    const int col = static_cast<int>(std::floor((x.y() - dem.east0_m) / dem.cell_m));
    const int row = static_cast<int>(std::floor((dem.north0_m - x.x()) / dem.cell_m));
    if (col < 0 || row < 0 || col >= dem.cols || row >= dem.rows) continue;
    const uint8_t s = seen[static_cast<std::size_t>(row) * dem.cols + col];
    if (s == products::kTruthMarginal || (s == products::kTruthSeen && k % 16 != 0)) continue;
    const double range = (x - datum.centre).head<2>().norm();
    if (range > range_m) continue;
    const auto it = left_of_pair.find(dense::linePair(p.line));
    if (it == left_of_pair.end()) continue;
    const Vec3 q = datum.align(x);
    double z = 0.0;
    if (!ortho::demElevation(truth, q.x(), q.y(), z)) continue;
    ++counted;
    const double sigma = std::max(1e-4, p.sigmaHeight_m());
    const double dz = -q.z() - z;
    Tally& t = (s == products::kTruthUnseen ? unseen : control)[std::upper_bound(kEdges, kEdges + kBands, range) - kEdges - 1];
    ++t.points;
    if (s == products::kTruthUnseen) ++unseen_by_pair[dense::linePair(p.line)];
    t.dz.push_back(dz);
    t.dz_over_sigma.push_back(dz / sigma);
    const bool high = dz > 3 * sigma;
    t.high += high;
    t.low += dz < -3 * sigma;
    t.within += std::fabs(dz) <= 3 * sigma;
    // The horizontal error of a point along its line of sight: its range sigma (~ its height sigma over the
    // grazing tangent), so the ray is tested up to three of them before the point.
    const Vec3& c = models[it->second].c;
    const double horizontal = (q - c).head<2>().norm();
    const double tan_grazing = std::max(1e-3, (q.z() - c.z()) / horizontal);
    const double clearance = lowestClearance(truth, c, q, std::max(truth.cell_m, 3 * sigma / tan_grazing));
    if (clearance < -3 * sigma) {
      ++t.through;
      t.through_high += high;
      t.ray_depth.push_back(-clearance);
    } else if (clearance <= 3 * sigma) {
      ++t.grazing;
    } else {
      ++t.clear;
      t.clear_high += high;
    }
  }
  std::printf("%s: %zu points read, %lld classed; DEM cell %.3f m\n", out.c_str(), pts.size(), counted, dem.cell_m);
  print("points in cells unseen in truth", unseen);
  print("control: every 16th point in cells seen in truth", control);
  std::printf("unseen-cell points by pair:");
  for (const auto& [pair, n] : unseen_by_pair) std::printf(" %lld:%lld", static_cast<long long>(pair), n);
  std::printf("\n");
  return 0;
}
