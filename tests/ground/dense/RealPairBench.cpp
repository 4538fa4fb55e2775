// Benchmark: areomap's dense matcher beside OpenCV StereoSGBM on one real Perseverance Navcam pair, in the
// same run, on the same rectified pair. The pair is read as the ground reads it (the raw-image record as
// served, its PNG as 8-bit grey) and rectified by the ground's rectification (ground/dense/Rectification.hpp)
// at full resolution; both matchers search the same disparity range, 0 to that of a point 1 m away
// (PairCloud's), with no tie points to narrow it. Printed per matcher:
//  - seconds of one matching of the left view (the right view's, for the check below, is not timed);
//  - density: valid pixels / pixels of the rectified overlap (left rectified pixels that show the left
//    original and whose row of the right rectified image shows the right original somewhere within the
//    disparity range);
//  - left-right consistency: of those valid pixels, the fraction whose disparity agrees within 1 px with the
//    same matcher's disparity of the right view at the matched pixel (the right view matched as a
//    mirrored pair);
//  and the ratios areomap / SGBM.
// StereoSGBM: MODE_SGBM (8 paths), block 5, P1 = 8 cn b^2, P2 = 32 cn b^2 (cn = 1, grey), uniqueness 10 %,
// disp12MaxDiff 1 (areomap's own left-right tolerance), speckle window 100 px of range 2, no pre-filter
// clipping beyond OpenCV's default 63.
// Usage: ground_real_pair_bench [--repeat N] [LEFT.json RIGHT.json]  (default: the sol 340 pair of
// ../shared/data/m2020-navcam-stereo-pairs; N: timed runs of each matcher, the fastest is printed)
// [--dump DIR]: writes areomap's left disparity as DIR/areomap_disparity.bin (raw float32) for byte checks.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "ground/dense/DenseMatcher.hpp"
#include "ground/dense/Rectification.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/io/ImageFile.hpp"
#include "tests/support/TestData.hpp"

using namespace areomap;

namespace {

double nowS() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

constexpr int kBlock = 5;

cv::Mat sgbm(const cv::Mat& l, const cv::Mat& r, int num_disp) {
  const int cn = 1;
  cv::Ptr<cv::StereoSGBM> m =
      cv::StereoSGBM::create(0, num_disp, kBlock, 8 * cn * kBlock * kBlock, 32 * cn * kBlock * kBlock, 1, 63,
                             10, 100, 2, cv::StereoSGBM::MODE_SGBM);
  cv::Mat d16, out;
  m->compute(l, r, d16);
  d16.convertTo(out, CV_32F, 1.0 / 16.0);
  out.setTo(NAN, d16 < 0);
  return out;
}

dense::DenseResult last_areomap;  // the stage times of the last areomap run

cv::Mat areomapMatch(const cv::Mat& l, const cv::Mat& r, int num_disp) {
  dense::DenseOptions o;
  o.max_disparity_px = num_disp - 1;
  last_areomap = dense::matchRectified(l, r, o);
  return last_areomap.disparity;
}

// The right view's disparity (right pixel x matches left x + d) by matching the mirrored pair.
template <class Match>
cv::Mat rightView(const cv::Mat& l, const cv::Mat& r, int num_disp, Match match) {
  cv::Mat fl, fr, d;
  cv::flip(r, fl, 1);
  cv::flip(l, fr, 1);
  cv::flip(match(fl, fr, num_disp), d, 1);
  return d;
}

cv::Mat shown(const cv::Mat& map) {
  cv::Mat m(map.rows, map.cols, CV_8U);
  for (int y = 0; y < map.rows; ++y) {
    for (int x = 0; x < map.cols; ++x) m.at<uint8_t>(y, x) = map.at<cv::Vec2f>(y, x)[0] >= 0 ? 255 : 0;
  }
  return m;
}

// Left rectified pixels showing the left original with some right-original pixel at x - d, 0 <= d < num_disp.
cv::Mat overlapMask(const dense::RectifiedPair& rect, int num_disp) {
  const cv::Mat l = shown(rect.left_map), r = shown(rect.right_map);
  cv::Mat out(l.size(), CV_8U, cv::Scalar(0));
  for (int y = 0; y < l.rows; ++y) {
    int last_right = -1000000;  // the last column <= x that shows the right original
    for (int x = 0; x < l.cols; ++x) {
      if (r.at<uint8_t>(y, x)) last_right = x;
      if (l.at<uint8_t>(y, x) && x - last_right < num_disp) out.at<uint8_t>(y, x) = 255;
    }
  }
  return out;
}

struct Figures {
  double seconds = 0.0;
  double density = 0.0;
  double lr = 0.0;
};

Figures score(double seconds, const cv::Mat& left, const cv::Mat& right, const cv::Mat& overlap) {
  long long area = 0, valid = 0, agree = 0;
  for (int y = 0; y < left.rows; ++y) {
    for (int x = 0; x < left.cols; ++x) {
      if (!overlap.at<uint8_t>(y, x)) continue;
      ++area;
      const float d = left.at<float>(y, x);
      if (std::isnan(d)) continue;
      ++valid;
      const int xr = static_cast<int>(std::lround(x - d));
      if (xr < 0 || xr >= right.cols) continue;
      const float dr = right.at<float>(y, xr);
      if (!std::isnan(dr) && std::fabs(dr - d) <= 1.0f) ++agree;
    }
  }
  Figures f;
  f.seconds = seconds;
  f.density = area > 0 ? static_cast<double>(valid) / static_cast<double>(area) : 0.0;
  f.lr = valid > 0 ? static_cast<double>(agree) / static_cast<double>(valid) : 0.0;
  return f;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string dir = test::sharedDataDir() + "/m2020-navcam-stereo-pairs/";
  std::string left_json = dir + "NLF_0340_0697121914_417ECM_N0090364NCAM00420_01_195J.json";
  std::string right_json = dir + "NRF_0340_0697121914_417ECM_N0090364NCAM00420_01_195J.json";
  std::string dump_dir;
  int repeat = 3, positional = 0;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--repeat") == 0 && i + 1 < argc) {
      repeat = std::max(1, std::atoi(argv[++i]));
    } else if (std::strcmp(argv[i], "--dump") == 0 && i + 1 < argc) {
      dump_dir = argv[++i];
    } else if (argv[i][0] != '-' && positional < 2) {
      (positional++ == 0 ? left_json : right_json) = argv[i];
    } else {
      std::fprintf(stderr,
                   "usage: ground_real_pair_bench [--repeat N] [--dump DIR] [LEFT.json RIGHT.json]\n");
      return 2;
    }
  }
  if (positional == 0 && !test::requireSharedData("m2020-navcam-stereo-pairs")) return 0;
  if (positional == 1) {
    std::fprintf(stderr, "ground_real_pair_bench: give both LEFT.json and RIGHT.json\n");
    return 2;
  }
  const io::CameraFile lf = io::readCameraFile(left_json), rf = io::readCameraFile(right_json);
  const cv::Mat lg = io::loadImage8(io::imageBeside(left_json)),
                rg = io::loadImage8(io::imageBeside(right_json));
  const dense::RectifiedPair rect = dense::rectifyPair(lf.model, rf.model);
  const cv::Mat l = dense::remapToRectified(lg, rect.left_map),
                r = dense::remapToRectified(rg, rect.right_map);
  const int d_max = static_cast<int>(std::ceil(dense::disparityAtRange(rect, 1.0)));
  const int num_disp = (d_max + 1 + 15) / 16 * 16;  // SGBM wants a multiple of 16; areomap gets the same
  const cv::Mat overlap = overlapMask(rect, num_disp);

  double t_sgbm = 1e30, t_areomap = 1e30;
  cv::Mat d_sgbm, d_areomap;
  for (int k = 0; k < repeat; ++k) {
    double t0 = nowS();
    d_sgbm = sgbm(l, r, num_disp);
    double t1 = nowS();
    d_areomap = areomapMatch(l, r, num_disp);
    double t2 = nowS();
    t_sgbm = std::min(t_sgbm, t1 - t0);
    t_areomap = std::min(t_areomap, t2 - t1);
    std::printf("run %d: SGBM %.3f s, areomap %.3f s (coarse %.3f, fine %.3f, post %.3f; fine cells %lld)\n",
                k + 1, t1 - t0, t2 - t1, last_areomap.coarse_seconds, last_areomap.fine_seconds,
                last_areomap.post_seconds, last_areomap.fine_cells);
  }
  const Figures s = score(t_sgbm, d_sgbm, rightView(l, r, num_disp, sgbm), overlap);
  const Figures a = score(t_areomap, d_areomap, rightView(l, r, num_disp, areomapMatch), overlap);

  std::printf(
      "## Dense matching on a real pair\n\n%s + %s: %dx%d originals, rectified %dx%d, disparity 0..%d, "
      "overlap %d px, fastest of %d runs\n\n",
      left_json.c_str(), right_json.c_str(), lg.cols, lg.rows, l.cols, l.rows, num_disp - 1,
      cv::countNonZero(overlap), repeat);
  std::printf("| matcher | seconds | density %% | LR consistent %% |\n|---|---|---|---|\n");
  std::printf("| OpenCV StereoSGBM (MODE_SGBM, block 5) | %.3f | %.2f | %.2f |\n", s.seconds, 100 * s.density,
              100 * s.lr);
  std::printf("| areomap | %.3f | %.2f | %.2f |\n", a.seconds, 100 * a.density, 100 * a.lr);
  std::printf("| areomap / SGBM | %.2f | %.3f | %.3f |\n", a.seconds / s.seconds, a.density / s.density,
              a.lr / s.lr);
  if (!dump_dir.empty()) {
    std::ofstream f(dump_dir + "/areomap_disparity.bin", std::ios::binary);
    for (int y = 0; y < d_areomap.rows; ++y)
      f.write(reinterpret_cast<const char*>(d_areomap.ptr<float>(y)), d_areomap.cols * sizeof(float));
  }
  return 0;
}
