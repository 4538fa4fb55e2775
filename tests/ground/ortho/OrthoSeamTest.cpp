// Seams of the orthoimage on panoramas rendered from a known texture: a ring of stereo pairs (CAHVOR with
// radial distortion, or CAHV) on a gimbal above a plane whose texture is an analytic pattern, the DEM the
// true plane. With true models and the true DEM the images agree everywhere, so a seam must not be
// visible: the grey step between two cells across a seam (their sources differ) must be that between
// neighbouring cells inside the images beside it, and the seam cells must be as close to the pattern as
// the others. The source of every cell is checked against an independent choice: the image nearest its
// centre among those that project the ground point inside and see it within their field (its off-axis
// angle at most that of the image's corners).
// The rigs: the navcam's distortion R = 0 .006 -.004 (its image radius turns back at ~70 degrees off the
// axis, so ground beside a camera projects into its image centre; an ortho that takes such a projection
// shows thin radial strips of foreign texture), a stronger distortion, and CAHV; several pair counts,
// tilts, bases, slopes, texture phases.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include <opencv2/core.hpp>

#include "ground/ortho/Orthoimage.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

struct Rig {
  const char* name;
  int pairs;
  double tilt_deg;          // optical axis below the horizontal
  double yaw0_deg;          // azimuth of the first pair
  double base_m;            // stereo base
  double r1, r2;            // CAHVOR radial terms (r0 = 0); both 0: CAHV
  double slope_n, slope_e;  // the plane: elevation = slope_n * north + slope_e * east
  unsigned seed;            // texture phases
};

constexpr int kWidth = 320, kHeight = 240;
constexpr double kFocalPx = 230.0;
constexpr double kMastM = 1.5;  // gimbal height above the origin of the plane

struct Texture {
  double phase[4];
  explicit Texture(unsigned seed) {
    for (int k = 0; k < 4; ++k) phase[k] = std::fmod(seed * (1.7 + 0.9 * k) + 0.3 * k, 2 * M_PI);
  }
  // Grey value of the ground at (north, east): wavelengths from 0.9 m down to 0.12 m (two to four image
  // pixels at 4 m), so that neighbouring cells differ by several DN.
  double at(double n, double e) const {
    return 128 + 45 * std::sin(7.0 * n + phase[0]) * std::cos(6.0 * e + phase[1]) +
           25 * std::sin(23.0 * n + 17.0 * e + phase[2]) + 15 * std::sin(31.0 * e - 41.0 * n + phase[3]);
  }
};

double elevation(const Rig& rig, double n, double e) {
  return rig.slope_n * n + rig.slope_e * e;
}

// The camera of pair `k`, side -1 (left) or +1 (right).
CameraModel seamCamera(const Rig& rig, int k, int side) {
  const double yaw = (rig.yaw0_deg + 360.0 * k / rig.pairs) * M_PI / 180.0;
  const double pitch = rig.tilt_deg * M_PI / 180.0;
  const Vec3 a(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw), std::sin(pitch));
  const Vec3 h = a.cross(Vec3(0, 0, -1)).normalized();  // image right
  const Vec3 v = a.cross(h).normalized();               // image down
  CameraModel m;
  m.type = rig.r1 == 0.0 && rig.r2 == 0.0 ? CameraType::kCahv : CameraType::kCahvor;
  m.c = Vec3(0, 0, -kMastM) + 0.5 * side * rig.base_m * h;
  m.a = a;
  m.h = kFocalPx * h + 0.5 * (kWidth - 1) * a;
  m.v = kFocalPx * v + 0.5 * (kHeight - 1) * a;
  m.o = a;
  m.r = Vec3(0.0, rig.r1, rig.r2);
  m.width = kWidth;
  m.height = kHeight;
  return m;
}

// Each pixel's ray intersected with the plane (z = -elevation, z down), the texture there.
cv::Mat renderSeamView(const Rig& rig, const Texture& tex, const CameraModel& m) {
  cv::Mat img(m.height, m.width, CV_8U, cv::Scalar(0));
  for (int y = 0; y < m.height; ++y) {
    for (int x = 0; x < m.width; ++x) {
      Vec3 o, d;
      if (unproject(m, Vec2(x, y), o, d) != Status::kOk) continue;
      const double den = d.z() + rig.slope_n * d.x() + rig.slope_e * d.y();
      if (den <= 1e-9) continue;
      const double t = -(o.z() + rig.slope_n * o.x() + rig.slope_e * o.y()) / den;
      const Vec3 p = o + t * d;
      img.at<uint8_t>(y, x) = static_cast<uint8_t>(std::lround(std::clamp(tex.at(p.x(), p.y()), 1.0, 255.0)));
    }
  }
  return img;
}

// The largest angle between a pixel's ray and the distortion axis (the optical axis for CAHV), from the
// image's border pixels: radial distortion is monotonic over the image, so its field is that cone.
double fieldAngle(const CameraModel& m) {
  const Vec3 axis = m.type == CameraType::kCahv ? m.a : m.o;
  double worst = 0.0;
  for (int i = 0; i < 2 * (m.width + m.height); ++i) {
    const Vec2 px = i < m.width                  ? Vec2(i, 0)
                    : i < 2 * m.width            ? Vec2(i - m.width, m.height - 1)
                    : i < 2 * m.width + m.height ? Vec2(0, i - 2 * m.width)
                                                 : Vec2(m.width - 1, i - 2 * m.width - m.height);
    Vec3 o, d;
    if (unproject(m, px, o, d) == Status::kOk)
      worst = std::max(worst, std::acos(std::clamp(d.dot(axis), -1.0, 1.0)));
  }
  return worst;
}

// Whether `chosen` (-1: none) is the independent choice for ground point `p`: among the images that
// project it inside (2 px from the edge, as the ortho's border) and see it within their field (fieldAngle),
// the one whose projection lies nearest its centre. Exact ties (a left and a right image symmetric about
// the point) may go either way.
bool isIndependentChoice(const std::vector<ortho::OrthoSource>& src, const std::vector<double>& field,
                         const Vec3& p, int chosen) {
  std::vector<double> dist(src.size(), -1.0);  // from the image centre; -1: not a candidate
  double best = -1.0;
  for (std::size_t i = 0; i < src.size(); ++i) {
    const CameraModel& m = src[i].model;
    Vec2 px;
    if (project(m, p, px) != Status::kOk || px.x() < 2 || px.y() < 2 || px.x() > kWidth - 3 ||
        px.y() > kHeight - 3) {
      continue;
    }
    const Vec3 axis = m.type == CameraType::kCahv ? m.a : m.o;
    if (std::acos(std::clamp((p - m.c).normalized().dot(axis), -1.0, 1.0)) > field[i]) continue;
    dist[i] = std::hypot(px.x() - 0.5 * (kWidth - 1), px.y() - 0.5 * (kHeight - 1));
    if (best < 0 || dist[i] < best) best = dist[i];
  }
  if (chosen < 0) return best < 0;
  const double d = dist[static_cast<std::size_t>(chosen)];
  return d >= 0 && d <= best + 1e-9;
}

struct SeamFigures {
  long long cells = 0, seam_pairs = 0, wrong_source = 0, seam_cells = 0;
  double step_across = 0, step_beside = 0;  // mean |grey step| across seams, beside them inside the images
  double rms_all = 0, rms_seam = 0;         // grey RMS against the texture: all cells, seam cells
};

SeamFigures measure(const Rig& rig) {
  const Texture tex(rig.seed);
  std::vector<ortho::OrthoSource> src;
  std::vector<double> field;
  for (int k = 0; k < rig.pairs; ++k) {
    for (int side : {-1, 1}) {
      src.push_back({cv::Mat(), seamCamera(rig, k, side)});
      src.back().grey = renderSeamView(rig, tex, src.back().model);
      field.push_back(fieldAngle(src.back().model));
    }
  }
  DemGrid dem;
  dem.cell_m = 0.03;
  dem.cols = dem.rows = 400;
  dem.east0_m = -6.0;
  dem.north0_m = 6.0;
  dem.values.resize(static_cast<std::size_t>(dem.cols) * dem.rows);
  for (int r = 0; r < dem.rows; ++r)
    for (int c = 0; c < dem.cols; ++c)
      dem.at(c, r) = static_cast<float>(elevation(rig, dem.northOfRow(r), dem.eastOfCol(c)));
  const ortho::OrthoResult o = ortho::makeOrthoimage(dem, src, ortho::OrthoOptions{});

  SeamFigures f;
  const auto source = [&](int r, int c) { return o.source.at<int16_t>(r, c); };
  const auto grey = [&](int r, int c) { return static_cast<int>(o.image.at<uint8_t>(r, c)); };
  cv::Mat on_seam = cv::Mat::zeros(dem.rows, dem.cols, CV_8U);
  for (int r = 2; r + 2 < dem.rows; ++r) {
    for (int c = 2; c + 2 < dem.cols; ++c) {
      // A step east or south across a seam, with the same source on the step before and after it.
      for (const cv::Point d : {cv::Point(1, 0), cv::Point(0, 1)}) {
        const int a = source(r, c), b = source(r + d.y, c + d.x);
        if (a < 0 || b < 0 || a == b) continue;
        on_seam.at<uint8_t>(r, c) = on_seam.at<uint8_t>(r + d.y, c + d.x) = 1;
        if (source(r - d.y, c - d.x) != a || source(r + 2 * d.y, c + 2 * d.x) != b) continue;
        f.step_across += std::abs(grey(r, c) - grey(r + d.y, c + d.x));
        f.step_beside += 0.5 * (std::abs(grey(r - d.y, c - d.x) - grey(r, c)) +
                                std::abs(grey(r + d.y, c + d.x) - grey(r + 2 * d.y, c + 2 * d.x)));
        ++f.seam_pairs;
      }
    }
  }
  f.step_across /= std::max(1LL, f.seam_pairs);
  f.step_beside /= std::max(1LL, f.seam_pairs);
  double s2_all = 0, s2_seam = 0;
  for (int r = 0; r < dem.rows; ++r) {
    for (int c = 0; c < dem.cols; ++c) {
      const double n = dem.northOfRow(r), e = dem.eastOfCol(c);
      const Vec3 p(n, e, -elevation(rig, n, e));
      const int s = source(r, c);
      f.wrong_source += !isIndependentChoice(src, field, p, s);
      if (s < 0) continue;
      const double err = grey(r, c) - std::clamp(tex.at(n, e), 1.0, 255.0);
      ++f.cells;
      s2_all += err * err;
      if (on_seam.at<uint8_t>(r, c)) {
        s2_seam += err * err;
        ++f.seam_cells;
      }
    }
  }
  f.rms_all = std::sqrt(s2_all / std::max(1LL, f.cells));
  f.rms_seam = std::sqrt(s2_seam / std::max(1LL, f.seam_cells));
  std::printf(
      "\n  %-34s %lld cells, %lld on seams; |step| across seams %.2f DN, beside them %.2f DN (ratio %.3f, "
      "%lld steps); grey RMS vs texture %.2f DN, on seams %.2f DN; %lld cells off the independent choice",
      rig.name, f.cells, f.seam_cells, f.step_across, f.step_beside, f.step_across / f.step_beside,
      f.seam_pairs, f.rms_all, f.rms_seam, f.wrong_source);
  return f;
}

}  // namespace

TEST_GROUP(OrthoSeams){};

TEST(OrthoSeams, SeamsAreInvisibleOnRenderedPanoramas) {
  const Rig rigs[] = {
      {"navcam R, 8 pairs, tilt 40, flat", 8, 40.0, 0.0, 0.20, 0.006, -0.004, 0.0, 0.0, 1},
      {"navcam R, 7 pairs, tilt 32, slope", 7, 32.0, 11.0, 0.30, 0.006, -0.004, 0.06, -0.04, 2},
      {"strong R, 9 pairs, tilt 45, slope", 9, 45.0, 23.0, 0.12, 0.01, -0.01, -0.03, 0.05, 3},
      {"CAHV, 10 pairs, tilt 50, flat", 10, 50.0, 5.0, 0.25, 0.0, 0.0, 0.0, 0.0, 4},
  };
  for (const Rig& rig : rigs) {
    const SeamFigures f = measure(rig);
    CHECK(f.cells > 50000);
    CHECK(f.seam_pairs > 1000);
    CHECK_EQUAL(0, f.wrong_source);
    // The two images at a seam sample the same texture at the same ground point, each bilinearly from its
    // own pixels (footprints of different size and shape): the step across differs from the step beside
    // only by that resampling. 10 %: a foreign cell (another place's texture) makes it ~1.5-2.5 x.
    CHECK_TEXT(f.step_across <= 1.10 * f.step_beside, rig.name);
    // Seam cells as faithful to the texture as the others, with the same resampling allowance (+0.5 DN:
    // the 8-bit rounding of image and ortho).
    CHECK_TEXT(f.rms_seam <= 1.10 * f.rms_all + 0.5, rig.name);
  }
  std::printf("\n");
}
