// Benchmark: areomap's dense matcher beside OpenCV StereoSGBM on one real Perseverance Navcam pair, in the
// same run, on the same rectified pair, with areomap's matcher run as the ground pass runs it. The pair's
// records are written as a dataset (tests/ground/pass PassChecks: writeRecordDatasets) and the ground pass
// runs on it (ground/pass runGroundPass: the ground's own tie matching, the adjustment, the hold-out check);
// the products' inputs come from the pass it returns (ground/pass passProductInputs: adjusted models, ties)
// and the pair's dense inputs as the cloud stage makes them (products::pairDenseInputs), then
// dense::pairMatchSetup gives the rectified pair, the matcher's options and the per-row parallax ranges
// from the ties, exactly what dense::pairCloud matches. StereoSGBM gets the same rectified images and the
// disparity range that the parallax ranges span (minDisparity = their lowest, numDisparities = their span
// rounded up to a multiple of 16). Printed per matcher:
//  - seconds of one matching of the left view (the right view's, for the check below, is not timed), wall
//    clock and the process's CPU time (every thread's; both matchers run here on one thread unless OpenCV's
//    own functions spread, OPENCV_FOR_THREADS_NUM=1 keeps them on one);
//  - density: dense::keepMatchesInside for both (PairCloud::matched_fraction: valid matches inside both
//    originals over the rectified pixels that show the left original, eroded by the matching window);
//  - left-right consistency: of those valid pixels, the fraction whose disparity agrees within 1 px with the
//    same matcher's disparity of the right view at the matched pixel (the right view matched as a mirrored
//    pair with the same ranges);
//  each over the pixels that show the left original, over those whose ray meets the level ground within the
//  DEM's range, and over those of the latter whose terrain lies within that range by either matcher's
//  parallax (nearTerrain); and the ratios areomap / SGBM. A second table (unless --no-blind) runs both
//  without ties: disparity 0 to that of a point 1 m away, the whole range on every row.
// StereoSGBM: MODE_SGBM (8 paths), block 5, P1 = 8 cn b^2, P2 = 32 cn b^2 (cn = 1, grey), uniqueness 10 %,
// disp12MaxDiff 1 (areomap's own left-right tolerance), speckle window 100 px of range 2, pre-filter cap 63.
// Usage: ground_real_pair_bench [--repeat N] [--no-blind] [--dump DIR] [--fine-block B] [--fill-block F]
// [--speckle AREA STEP] [LEFT.json RIGHT.json] (--fine-block, --fill-block, --speckle: DenseOptions::
// fine_block_px, fill_block_px, speckle_max_area_px and speckle_max_step_px instead of the pass's; default:
// the sol 340 pair of ../shared/data/m2020-navcam-stereo-pairs; N: timed runs of each matcher, the fastest
// is printed; --dump DIR: areomap's left disparity as the pass matches it, DIR/areomap_disparity.bin, raw
// float32, for byte checks, and PNGs of the rectified left image, the region and both disparities).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <string>
#include <ctime>

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "ground/dataset/Dataset.hpp"
#include "ground/dense/PairCloud.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/pass/GroundPass.hpp"
#include "ground/pass/PassProducts.hpp"
#include "tests/ground/pass/PassChecks.hpp"
#include "tests/support/TestData.hpp"

using namespace areomap;

namespace {

double nowS() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// The CPU time of the process (all its threads): on a machine shared with other work, wall-clock times
// grow with the load, CPU times much less.
double cpuS() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

constexpr int kBlock = 5;

struct Search {
  int min_px = 0, max_px = 0;  // SGBM's range, inclusive (its count rounded up to a multiple of 16)
  int areomap_min_px = 0, areomap_max_px = 0;          // DenseOptions min/max_disparity_px
  const std::vector<dense::RowRange>* rows = nullptr;  // areomap's per-row ranges (nullptr: min..max)
  // areomap's mask of the pixels it matches (PairMatchSetup::match_mask), of the left view and of the
  // right view mirrored (rightView); SGBM matches every pixel.
  cv::Mat mask, mirrored_right_mask;
  int sgbmCount() const { return (max_px - min_px + 1 + 15) / 16 * 16; }
};

using Matcher = std::function<cv::Mat(const cv::Mat&, const cv::Mat&, const Search&)>;

cv::Mat sgbm(const cv::Mat& l, const cv::Mat& r, const Search& s) {
  const int cn = 1;
  cv::Ptr<cv::StereoSGBM> m =
      cv::StereoSGBM::create(s.min_px, s.sgbmCount(), kBlock, 8 * cn * kBlock * kBlock,
                             32 * cn * kBlock * kBlock, 1, 63, 10, 100, 2, cv::StereoSGBM::MODE_SGBM);
  cv::Mat d16, out;
  m->compute(l, r, d16);
  d16.convertTo(out, CV_32F, 1.0 / 16.0);
  out.setTo(NAN, d16 < s.min_px * 16);  // OpenCV marks no match as (minDisparity - 1) * 16
  return out;
}

// areomap's matcher with the pass's options (`base`), the search of `s`.
Matcher areomapMatcher(const dense::DenseOptions& base, dense::DenseResult& last) {
  return [&base, &last](const cv::Mat& l, const cv::Mat& r, const Search& s) {
    dense::DenseOptions o = base;
    o.min_disparity_px = s.areomap_min_px;
    o.max_disparity_px = s.areomap_max_px;
    last = dense::matchRectified(l, r, o, s.rows, s.mask);
    return last.disparity;
  };
}

// The right view's disparity (right pixel x matches left x + d) by matching the mirrored pair: its
// disparities are positive and on the same rows, so the same search applies.
cv::Mat rightView(const cv::Mat& l, const cv::Mat& r, const Search& s, const Matcher& match) {
  cv::Mat fl, fr, d;
  cv::flip(r, fl, 1);
  cv::flip(l, fr, 1);
  Search mirrored = s;
  mirrored.mask = s.mirrored_right_mask;
  cv::flip(match(fl, fr, mirrored), d, 1);
  return d;
}

// Rectified left pixels that show the left original (dense::insideOriginal) and, of them, those whose ray
// meets the level ground under the rover within the DEM's range (`range_m` horizontally from the camera):
// the terrain the products map, without the sky and the horizon. The models are the records' (rover
// navigation frame, z = 0 the plane of the wheels); `rover_to_site` (the record's attitude) levels them.
struct Regions {
  cv::Mat shown, ground;
};

Regions regions(const dense::RectifiedPair& rect, const Eigen::Matrix3d& rover_to_site, double range_m) {
  Regions r;
  r.shown = dense::insideOriginal(rect.left_map);
  r.ground = cv::Mat(r.shown.size(), CV_8U, cv::Scalar(0));
  const CameraModel& m = rect.left;
  const double height_m = -(rover_to_site * m.c).z();  // +Z down: the camera above the wheels' level
  for (int y = 0; y < r.shown.rows; ++y) {
    for (int x = 0; x < r.shown.cols; ++x) {
      Vec3 dir = (m.h - x * m.a).cross(m.v - y * m.a);
      if (dir.dot(m.a) < 0) dir = -dir;
      dir = rover_to_site * dir;
      if (!r.shown.at<uint8_t>(y, x) || dir.z() <= 0) continue;
      if (height_m / dir.z() * dir.head<2>().norm() <= range_m) r.ground.at<uint8_t>(y, x) = 255;
    }
  }
  return r;
}

struct Figures {
  double seconds = 0.0, cpu_seconds = 0.0;
  double density = 0.0, lr = 0.0;                // over the pixels that show the left original
  double ground_density = 0.0, ground_lr = 0.0;  // over those that see the ground within the DEM range
  double near_density = 0.0, near_lr = 0.0;      // over the near terrain (nearTerrain)
};

// Of the level-ground region, the pixels whose terrain lies within the DEM's range by the parallax of
// either matcher (at least `d_min`): the real ground is not level, and rows that the level ground puts
// within range may show terrain hundreds of metres away, which no product uses. Either matcher's parallax
// counts, so that neither is scored only where it matched.
cv::Mat nearTerrain(const cv::Mat& ground, const cv::Mat& a, const cv::Mat& b, double d_min) {
  cv::Mat out = cv::Mat::zeros(ground.size(), CV_8U);
  for (int y = 0; y < ground.rows; ++y)
    for (int x = 0; x < ground.cols; ++x)
      if (ground.at<uint8_t>(y, x) && (a.at<float>(y, x) >= d_min || b.at<float>(y, x) >= d_min))
        out.at<uint8_t>(y, x) = 255;
  return out;
}

// Density and left-right consistency of `left` (matches kept inside both originals first) in `region`.
void score(const cv::Mat& left, const cv::Mat& right, const cv::Mat& region, double& density, double& lr) {
  long long valid = 0, agree = 0;
  for (int y = 0; y < left.rows; ++y) {
    for (int x = 0; x < left.cols; ++x) {
      const float d = left.at<float>(y, x);
      if (std::isnan(d) || !region.at<uint8_t>(y, x)) continue;
      ++valid;
      const int xr = static_cast<int>(std::lround(x - d));
      if (xr < 0 || xr >= right.cols) continue;
      const float dr = right.at<float>(y, xr);
      if (!std::isnan(dr) && std::fabs(dr - d) <= 1.0f) ++agree;
    }
  }
  density = static_cast<double>(valid) / std::max(1.0, static_cast<double>(cv::countNonZero(region)));
  lr = valid > 0 ? static_cast<double>(agree) / static_cast<double>(valid) : 0.0;
}

// `kept`: the left disparities with only the matches inside both originals (dense::keepMatchesInside).
Figures score(double seconds, double cpu_seconds, const Regions& regions, const cv::Mat& near,
              const cv::Mat& kept, const cv::Mat& right) {
  Figures f;
  f.seconds = seconds;
  f.cpu_seconds = cpu_seconds;
  score(kept, right, regions.shown, f.density, f.lr);
  score(kept, right, regions.ground, f.ground_density, f.ground_lr);
  score(kept, right, near, f.near_density, f.near_lr);
  return f;
}

// Both matchers on the pair with search `s`: the fastest of `repeat` timed runs, then the scores.
void compare(const char* title, const dense::PairMatchSetup& p, const Regions& regions, double range_m,
             const Search& s, int repeat, const Matcher& areomap, const dense::DenseResult& last,
             cv::Mat* areomap_disparity) {
  double t_sgbm = 1e30, t_areomap = 1e30, cpu_sgbm = 1e30, cpu_areomap = 1e30;
  cv::Mat d_sgbm, d_areomap;
  for (int k = 0; k < repeat; ++k) {
    const double t0 = nowS(), c0 = cpuS();
    d_sgbm = sgbm(p.left, p.right, s);
    const double t1 = nowS(), c1 = cpuS();
    d_areomap = areomap(p.left, p.right, s);
    const double t2 = nowS(), c2 = cpuS();
    t_sgbm = std::min(t_sgbm, t1 - t0);
    t_areomap = std::min(t_areomap, t2 - t1);
    cpu_sgbm = std::min(cpu_sgbm, c1 - c0);
    cpu_areomap = std::min(cpu_areomap, c2 - c1);
    std::printf(
        "%s run %d: SGBM %.3f s (CPU %.3f s), areomap %.3f s (CPU %.3f s; coarse %.3f, fine %.3f of which fill "
        "%.3f, post %.3f; fine cells %lld)\n",
        title, k + 1, t1 - t0, c1 - c0, t2 - t1, c2 - c1, last.coarse_seconds, last.fine_seconds,
        last.fill_seconds, last.post_seconds, last.fine_cells);
  }
  if (areomap_disparity != nullptr) *areomap_disparity = d_areomap.clone();
  dense::keepMatchesInside(p.rect, d_areomap);
  dense::keepMatchesInside(p.rect, d_sgbm);
  const double d_min = dense::disparityAtRange(p.rect, range_m);
  const cv::Mat near = nearTerrain(regions.ground, d_areomap, d_sgbm, d_min);
  const Figures a =
      score(t_areomap, cpu_areomap, regions, near, d_areomap, rightView(p.left, p.right, s, areomap));
  const Figures g = score(t_sgbm, cpu_sgbm, regions, near, d_sgbm, rightView(p.left, p.right, s, sgbm));
  std::printf("\n%s: SGBM disparity %d..%d (numDisparities %d); areomap %d..%d, %s\n\n", title, s.min_px,
              s.min_px + s.sgbmCount() - 1, s.sgbmCount(), s.areomap_min_px, s.areomap_max_px,
              s.rows ? "per-row parallax ranges from the ties" : "the whole range on every row");
  std::printf(
      "| matcher | seconds | CPU seconds | density %% | LR consistent %% | level ground to %.0f m: density %% | LR %% | "
      "terrain to %.0f m (parallax >= %.1f px): density %% | LR %% |\n"
      "|---|---|---|---|---|---|---|---|---|\n",
      range_m, range_m, d_min);
  const auto row = [](const char* name, const Figures& f) {
    std::printf("| %s | %.3f | %.3f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |\n", name, f.seconds, f.cpu_seconds,
                100 * f.density,
                100 * f.lr, 100 * f.ground_density, 100 * f.ground_lr, 100 * f.near_density, 100 * f.near_lr);
  };
  row("OpenCV StereoSGBM (MODE_SGBM, block 5)", g);
  row("areomap", a);
  std::printf("| areomap / SGBM | %.2f | %.2f | %.3f | %.3f | %.3f | %.3f | %.3f | %.3f |\n\n",
              a.seconds / g.seconds, a.cpu_seconds / g.cpu_seconds, a.density / g.density, a.lr / g.lr, a.ground_density / g.ground_density,
              a.ground_lr / g.ground_lr, a.near_density / g.near_density, a.near_lr / g.near_lr);
}

}  // namespace

// Long because: the benchmark's steps (arguments, the ground pass, the pair's set-up, both tables, the dump)
// in the order they run, each printed as it goes.
int main(int argc, char** argv) {
  const std::string dir = test::sharedDataDir() + "/m2020-navcam-stereo-pairs/";
  std::string left_json = dir + "NLF_0340_0697121914_417ECM_N0090364NCAM00420_01_195J.json";
  std::string right_json = dir + "NRF_0340_0697121914_417ECM_N0090364NCAM00420_01_195J.json";
  std::string dump_dir;
  int repeat = 3, positional = 0, fine_block = 0, fill_block = -1, speckle_area = -2;
  double speckle_step = 0.0;
  bool blind = true;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--repeat") == 0 && i + 1 < argc) {
      repeat = std::max(1, std::atoi(argv[++i]));
    } else if (std::strcmp(argv[i], "--dump") == 0 && i + 1 < argc) {
      dump_dir = argv[++i];
    } else if (std::strcmp(argv[i], "--fine-block") == 0 && i + 1 < argc) {
      fine_block = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--fill-block") == 0 && i + 1 < argc) {
      fill_block = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--speckle") == 0 && i + 2 < argc) {
      speckle_area = std::atoi(argv[++i]);
      speckle_step = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--no-blind") == 0) {
      blind = false;
    } else if (argv[i][0] != '-' && positional < 2) {
      (positional++ == 0 ? left_json : right_json) = argv[i];
    } else {
      std::fprintf(stderr,
                   "usage: ground_real_pair_bench [--repeat N] [--no-blind] [--dump DIR] [--fine-block B] "
                   "[--fill-block F] [--speckle AREA STEP] [LEFT.json RIGHT.json]\n");
      return 2;
    }
  }
  if (positional == 0 && !test::requireSharedData("m2020-navcam-stereo-pairs")) return 0;
  if (positional == 1) {
    std::fprintf(stderr, "ground_real_pair_bench: give both LEFT.json and RIGHT.json\n");
    return 2;
  }

  // The pair alone as a dataset (its records and images beside each other), then the ground pass on it.
  namespace fs = std::filesystem;
  const std::string scratch = test::scratchDir("real-pair-bench");
  fs::create_directories(scratch + "/records");
  for (const std::string& json : {left_json, right_json}) {
    const fs::path p(json);
    fs::copy_file(p, scratch + "/records/" + p.filename().string(), fs::copy_options::overwrite_existing);
    fs::copy_file(fs::path(p).replace_extension(".png"), scratch + "/records/" + p.stem().string() + ".png",
                  fs::copy_options::overwrite_existing);
  }
  // areomap-dataset, as a user turns downloaded frames into a dataset.
  std::vector<std::string> dirs;
  fs::remove_all(scratch + "/datasets");
  if (test::runTool("areomap-dataset", "'" + scratch + "/records' --out '" + scratch + "/datasets'") == 0) {
    std::ifstream in(scratch + "/datasets/index.json");
    const nlohmann::json index = nlohmann::json::parse(in, nullptr, false);
    if (!index.is_discarded() && index.contains("datasets"))
      for (const nlohmann::json& d : index["datasets"]) dirs.push_back(scratch + "/datasets/" + d.value("name", ""));
  }
  if (dirs.size() != 1) {
    std::fprintf(stderr, "ground_real_pair_bench: %s and %s are not one pair\n", left_json.c_str(),
                 right_json.c_str());
    return 2;
  }
  const Dataset dataset = readDataset(dirs[0]);
  ground::GroundPassOptions options;
  options.out_dir = scratch + "/out";
  options.progress = false;
  const double t_pass = nowS();
  const ground::SitePass pass = ground::runGroundPass(dataset, options, nullptr, nullptr);
  const products::ProductInputs inputs = ground::passProductInputs(pass);
  if (inputs.pairs.empty() || inputs.pairs[0].right < 0) {
    std::fprintf(stderr, "ground_real_pair_bench: the pass made no pair\n");
    return 1;
  }
  const products::ProductPair& pair = inputs.pairs[0];
  const products::PairDenseInputs pd = products::pairDenseInputs(inputs, ground::passProductOptions(), pair);
  const dense::PairMatchSetup p =
      dense::pairMatchSetup(pd.left, pd.right, inputs.images[pair.left].grey, inputs.images[pair.right].grey,
                            pd.left_ties_px, pd.right_ties_px, pd.options);
  Search pass_search{p.options.min_disparity_px, p.options.max_disparity_px, p.options.min_disparity_px,
                     p.options.max_disparity_px, p.ranges.empty() ? nullptr : &p.ranges, p.match_mask, cv::Mat()};
  cv::flip(dense::insideOriginal(p.rect.right_map), pass_search.mirrored_right_mask, 1);
  if (!p.ranges.empty()) {
    pass_search.min_px = p.ranges[0].lo;
    pass_search.max_px = p.ranges[0].hi;
    for (const dense::RowRange& r : p.ranges) {
      pass_search.min_px = std::min(pass_search.min_px, r.lo);
      pass_search.max_px = std::max(pass_search.max_px, r.hi);
    }
  }
  const double range_m = ground::passProductOptions().max_range_m;
  const std::optional<Eigen::Vector4d> q = io::readCameraFile(left_json).acquisition.attitude;
  const Eigen::Matrix3d rover_to_site =
      q ? Eigen::Quaterniond((*q)(0), (*q)(1), (*q)(2), (*q)(3)).normalized().toRotationMatrix()
        : Eigen::Matrix3d::Identity();
  const Regions reg = regions(p.rect, rover_to_site, range_m);
  const dense::ParallaxCurve curve = dense::fitParallaxCurve(p.ties, p.left.rows);
  double tie_rows[2] = {1e30, -1e30};
  for (const dense::TieDisparity& t : p.ties) {
    tie_rows[0] = std::min(tie_rows[0], t.y_px);
    tie_rows[1] = std::max(tie_rows[1], t.y_px);
  }
  double band = 0.0;
  for (const dense::RowRange& r : p.ranges) band += r.hi - r.lo + 1;
  std::printf(
      "## Dense matching on a real pair\n\n%s + %s: %dx%d originals, rectified %dx%d; the ground pass (%.1f "
      "s: "
      "%d tie points, %d rejected, method 1 %.3f -> %.3f px) gave %zu ties to the pair (rows %.0f..%.0f), "
      "parallax curve "
      "%.1f..%.1f px (sigma %.2f px, %d inliers), per-row ranges %.0f px wide on average within %d..%d; "
      "%d pixels show the left original, %d of them see the ground within %.0f m; fastest of %d runs\n\n",
      left_json.c_str(), right_json.c_str(), inputs.images[pair.left].grey.cols,
      inputs.images[pair.left].grey.rows, p.left.cols, p.left.rows, nowS() - t_pass, pass.summary.points,
      pass.summary.rejected_observations, pass.summary.method1_before_px, pass.summary.method1_after_px,
      p.ties.size(), tie_rows[0], tie_rows[1], curve.at(0, p.left.rows), curve.at(p.left.rows - 1, p.left.rows), curve.sigma_px,
      curve.inliers, p.ranges.empty() ? 0.0 : band / static_cast<double>(p.ranges.size()), pass_search.min_px,
      pass_search.max_px, cv::countNonZero(reg.shown), cv::countNonZero(reg.ground), range_m, repeat);

  dense::DenseResult last;
  dense::DenseOptions dense_options = p.options;
  if (fine_block > 0) dense_options.fine_block_px = fine_block;
  if (fill_block >= 0) dense_options.fill_block_px = fill_block;
  if (speckle_area >= -1) {
    dense_options.speckle_max_area_px = speckle_area;
    dense_options.speckle_max_step_px = speckle_step;
  }
  const Matcher areomap = areomapMatcher(dense_options, last);
  cv::Mat d_pass;
  compare("As the ground pass matches it", p, reg, range_m, pass_search, repeat, areomap, last, &d_pass);
  if (blind) {
    Search s{0, p.options.max_disparity_px, 0, 0, nullptr, pass_search.mask, pass_search.mirrored_right_mask};
    s.areomap_max_px = s.sgbmCount() - 1;  // both search 0 to SGBM's rounded-up count
    compare("Blind (no ties)", p, reg, range_m, s, repeat, areomap, last, nullptr);
  }
  if (!dump_dir.empty()) {
    std::ofstream f(dump_dir + "/areomap_disparity.bin", std::ios::binary);
    for (int y = 0; y < d_pass.rows; ++y)
      f.write(reinterpret_cast<const char*>(d_pass.ptr<float>(y)), d_pass.cols * sizeof(float));
    // For the eye: the rectified left image, the level-ground region and both disparities (2 grey levels
    // per pixel of parallax above 20; black = no match).
    const auto grey = [](const cv::Mat& d) {
      cv::Mat v(d.size(), CV_8U, cv::Scalar(0));
      for (int y = 0; y < d.rows; ++y)
        for (int x = 0; x < d.cols; ++x)
          if (!std::isnan(d.at<float>(y, x))) v.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(2 * d.at<float>(y, x) + 20);
      return v;
    };
    cv::imwrite(dump_dir + "/left.png", p.left);
    cv::imwrite(dump_dir + "/ground.png", reg.ground);
    cv::imwrite(dump_dir + "/areomap.png", grey(d_pass));
    cv::imwrite(dump_dir + "/sgbm.png", grey(sgbm(p.left, p.right, pass_search)));
  }
  return 0;
}
