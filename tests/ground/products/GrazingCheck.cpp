// Where the dense points that fall in ground no true camera sees come from (docs/products.md "Seen and
// unseen cells"):
//   grazing_check DATASET [--range M] [--step S]
// DATASET: a synthetic dataset (images, truth/models, truth/dem.tif). Each pair is matched as the products
// match it (pairMatchSetup, matchRectified) through its TRUE models, every S-th pixel each way triangulated;
// each point's place is classed by products::truthCellsSeen on a 5 cm grid (seen, marginal, unseen). Per
// range band and class: the points, the share of the fill pass's block matches, and the distribution of
// the point's vertical disparity gradient against the level ground's (columnGradientRatio below:
// the smaller one-sided disparity change over the rows about it, over what level ground under the cameras
// gives). The points that fall in unseen ground carry the seen ground's gradients, not a ramp's: they are
// the range noise of the ground at a shadow's ends (docs/products.md "Seen and unseen cells").
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/DemRaster.hpp"
#include "ground/dense/DenseMatcher.hpp"
#include "ground/dense/PairCloud.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/ortho/Orthoimage.hpp"
#include "ground/products/TruthSeen.hpp"

using namespace areomap;

namespace {

constexpr int kBandsG = 5;
constexpr double kEdgesG[kBandsG + 1] = {0, 5, 10, 15, 20, 1e9};
constexpr int kRatioBins = 8;
constexpr double kRatioEdges[kRatioBins] = {0.5, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0, 1e9};

struct Tally {
  long long points = 0, block = 0, no_ratio = 0;
  long long ratio[kRatioBins] = {};
};

// The smaller of a pixel's two one-sided column gradients of the disparity (from `reach` rows above to it,
// from it to `reach` rows below, per row) over `level` (baseline over the camera's height: level ground's
// gradient along a column); NaN where an end has no match. On a ramp across an occlusion edge (the matcher's
// evidence straddling a rock's top) both sides are steep; at a sharp edge one of them is the surface's own.
cv::Mat columnGradientRatio(const cv::Mat& disparity, double level, int reach) {
  cv::Mat out(disparity.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  for (int y = reach; y + reach < disparity.rows; ++y) {
    for (int x = 0; x < disparity.cols; ++x) {
      const float d = disparity.at<float>(y, x), up = disparity.at<float>(y - reach, x), down = disparity.at<float>(y + reach, x);
      if (!std::isfinite(d) || !std::isfinite(up) || !std::isfinite(down)) continue;
      out.at<float>(y, x) = static_cast<float>(std::min(d - up, down - d) / reach / level);  // rows grow towards the camera
    }
  }
  return out;
}

// The median of columnGradientRatio's finite values (level 1); 0 without any.
double medianColumnGradient(const cv::Mat& disparity, int reach) {
  const cv::Mat g = columnGradientRatio(disparity, 1.0, reach);
  std::vector<float> v;
  for (int y = 0; y < g.rows; ++y)
    for (int x = 0; x < g.cols; ++x)
      if (std::isfinite(g.at<float>(y, x))) v.push_back(g.at<float>(y, x));
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

// Long because: an evaluation tool, one pass over the pairs with its tallies.
int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: grazing_check DATASET [--range M] [--step S]\n");
    return 2;
  }
  const std::string root = argv[1];
  double range_m = 30.0;
  int step = 2;
  for (int i = 2; i + 1 < argc; i += 2) {
    if (std::string(argv[i]) == "--range") range_m = std::atof(argv[i + 1]);
    if (std::string(argv[i]) == "--step") step = std::max(1, std::atoi(argv[i + 1]));
  }
  const Dataset ds = readDataset(root);
  const DemGrid truth = readDemGeoTiff(root + "/truth/dem.tif");
  std::vector<cv::Mat> images;
  std::vector<CameraModel> models;
  for (const Pair& p : ds.pairs)
    for (const ImageRef* ref : {&p.left, p.right ? &*p.right : nullptr})
      if (ref != nullptr) {
        images.push_back(cv::imread(ref->image_path, cv::IMREAD_GRAYSCALE));
        models.push_back(io::readCameraModelFile(root + "/truth/models/" + ref->stem + ".cahvor", images.back().cols,
                                                 images.back().rows));
      }
  Vec3 g = Vec3::Zero();
  for (const CameraModel& m : models) g += m.c / static_cast<double>(models.size());
  DemGrid grid;
  grid.cell_m = 0.05;
  grid.east0_m = g.y() - range_m;
  grid.north0_m = g.x() + range_m;
  grid.cols = grid.rows = static_cast<int>(std::ceil(2 * range_m / grid.cell_m));
  grid.values.assign(static_cast<std::size_t>(grid.cols) * grid.rows, 0.0f);
  const std::vector<uint8_t> seen = products::truthCellsSeen(grid, truth, images, models, products::TruthFrame{});
  Tally tally[kBandsG][3];
  std::size_t image = 0;
  for (const Pair& p : ds.pairs) {
    if (!p.right) {
      ++image;
      continue;
    }
    const CameraModel &ml = models[image], &mr = models[image + 1];
    const cv::Mat &il = images[image], &ir = images[image + 1];
    image += 2;
    const dense::PairMatchSetup s = dense::pairMatchSetup(ml, mr, il, ir, {}, {}, dense::PairCloudOptions{});
    dense::DenseResult d = dense::matchRectified(s.left, s.right, s.options, s.ranges.empty() ? nullptr : &s.ranges,
                                                 s.match_mask);
    dense::keepMatchesInside(s.rect, d.disparity);
    double ground = 0.0;
    if (!ortho::demElevation(truth, ml.c.x(), ml.c.y(), ground)) continue;
    const double height_m = -ml.c.z() - ground;
    const int reach = std::getenv("GRAZING_REACH") ? std::atoi(std::getenv("GRAZING_REACH")) : 3;
    const cv::Mat ratio = columnGradientRatio(d.disparity, s.rect.baseline_m / height_m, reach);
    for (int y = 0; y < d.disparity.rows; y += step) {
      for (int x = 0; x < d.disparity.cols; x += step) {
        const float disp = d.disparity.at<float>(y, x);
        if (!std::isfinite(disp)) continue;
        dense::CloudPoint cp;
        if (!dense::triangulate(s.rect.left, s.rect.right, Vec2(x, y), Vec2(x - disp, y), 0.15, cp)) continue;
        const double range = std::hypot(cp.site_m.x() - g.x(), cp.site_m.y() - g.y());
        const int col = static_cast<int>(std::floor((cp.site_m.y() - grid.east0_m) / grid.cell_m));
        const int row = static_cast<int>(std::floor((grid.north0_m - cp.site_m.x()) / grid.cell_m));
        if (range > range_m || col < 0 || row < 0 || col >= grid.cols || row >= grid.rows) continue;
        int b = 0;
        while (range >= kEdgesG[b + 1]) ++b;
        Tally& t = tally[b][seen[static_cast<std::size_t>(row) * grid.cols + col]];
        ++t.points;
        t.block += d.block.at<uint8_t>(y, x) != 0;
        const float r = ratio.at<float>(y, x);
        if (!std::isfinite(r)) {
          ++t.no_ratio;
          continue;
        }
        int k = 0;
        while (k + 1 < kRatioBins && r >= kRatioEdges[k]) ++k;
        ++t.ratio[k];
      }
    }
    std::fprintf(stderr, "pair %d: camera %.2f m above the ground, the matches' median column gradient %.2f of "
                 "level ground's\n", p.id, height_m, medianColumnGradient(d.disparity, reach) * height_m / s.rect.baseline_m);
  }
  const char* names[3] = {"unseen", "marginal", "seen"};
  std::printf("| band m | class | points | block %% | no ratio %% | ratio <0.5 / <1 / <1.5 / <2 / <3 / <5 / <10 / more (%%) |\n");
  for (int b = 0; b < kBandsG; ++b) {
    for (int c = 0; c < 3; ++c) {
      const Tally& t = tally[b][c];
      const double n = static_cast<double>(std::max(1LL, t.points));
      std::printf("| %g-%g | %s | %lld | %.1f | %.1f |", kEdgesG[b], kEdgesG[b + 1], names[c], t.points, 100 * t.block / n,
                  100 * t.no_ratio / n);
      for (int k = 0; k < kRatioBins; ++k) std::printf(" %.1f", 100 * t.ratio[k] / n);
      std::printf(" |\n");
    }
  }
  return 0;
}
