// Orthoimage on a flat plane seen by two overlapping CAHV cameras whose images are rendered from a known
// ground pattern: every cell takes the pattern's value at its centre (bilinear resampling), from the image
// whose projection lies nearest its centre (checked against a direct computation), seams agree to a small
// fraction of a pixel; a DEM that is wrong by 10 cm makes the seam check report the disagreement.
#include <cmath>
#include <cstdio>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "ground/ortho/Orthoimage.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

double pattern(double north, double east) {
  return 128 + 60 * std::sin(north * 9.0) * std::cos(east * 7.0) + 30 * std::sin(north * 23.0 + east * 17.0);
}

// Camera 1.5 m above the plane (z = 0, z down) at `east_m`, looking along yaw, 40 degrees down; 400x300,
// f 350 px. The two cameras are 60 cm apart, so a DEM error moves their orthos against each other.
CameraModel camera(double yaw, double east_m) {
  const double pitch = 40.0 * M_PI / 180.0;
  const Vec3 a(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw), std::sin(pitch));
  const Vec3 h = a.cross(Vec3(0, 0, -1)).normalized();
  const Vec3 v = a.cross(h).normalized();
  CameraModel m;
  m.type = CameraType::kCahv;
  m.c = Vec3(0, east_m, -1.5);
  m.a = a;
  m.h = 350.0 * h + 199.5 * a;
  m.v = 350.0 * v + 149.5 * a;
  m.width = 400;
  m.height = 300;
  return m;
}

cv::Mat render(const CameraModel& m) {
  cv::Mat img(m.height, m.width, CV_8U);
  for (int y = 0; y < m.height; ++y) {
    for (int x = 0; x < m.width; ++x) {
      Vec3 o, d;
      if (unproject(m, Vec2(x, y), o, d) != Status::kOk || d.z() <= 1e-6) {
        img.at<uint8_t>(y, x) = 0;
        continue;
      }
      const Vec3 p = o + d * (-o.z() / d.z());
      img.at<uint8_t>(y, x) = static_cast<uint8_t>(std::lround(std::clamp(pattern(p.x(), p.y()), 1.0, 255.0)));
    }
  }
  return img;
}

DemGrid flatDem(float elevation) {
  DemGrid g;
  g.east0_m = -2.5;
  g.north0_m = 5.0;
  g.cell_m = 0.02;
  g.cols = 250;
  g.rows = 200;
  g.values.assign(static_cast<std::size_t>(g.cols) * g.rows, elevation);
  return g;
}

}  // namespace

TEST_GROUP(Orthoimage){};

TEST(Orthoimage, FlatGroundFromTwoImages) {
  std::vector<ortho::OrthoSource> src = {{cv::Mat(), camera(-0.25, -0.3)}, {cv::Mat(), camera(0.25, 0.3)}};
  for (auto& s : src) s.grey = render(s.model);
  const DemGrid dem = flatDem(0.0f);
  const ortho::OrthoResult o = ortho::makeOrthoimage(dem, src, ortho::OrthoOptions{});
  double s2 = 0;
  long long n = 0, wrong_source = 0, from[2] = {0, 0};
  for (int r = 0; r < dem.rows; ++r) {
    for (int c = 0; c < dem.cols; ++c) {
      if (!o.valid.at<uint8_t>(r, c)) continue;
      const Vec3 p(dem.northOfRow(r), dem.eastOfCol(c), 0.0);
      const double e = o.image.at<uint8_t>(r, c) - pattern(p.x(), p.y());
      s2 += e * e;
      ++n;
      // Independent choice: the smaller distance of the projection from the image centre.
      double best = 1e300;
      int chosen = -1;
      for (int i = 0; i < 2; ++i) {
        Vec2 px;
        if (project(src[i].model, p, px) != Status::kOk) continue;
        if (px.x() < 2 || px.y() < 2 || px.x() > 397 || px.y() > 297) continue;
        const double d = std::hypot(px.x() - 199.5, px.y() - 149.5);
        if (d < best) { best = d; chosen = i; }
      }
      wrong_source += chosen != o.source.at<int16_t>(r, c);
      ++from[o.source.at<int16_t>(r, c)];
    }
  }
  const double rms = std::sqrt(s2 / std::max(1LL, n));
  std::printf("\n  flat ortho: %lld cells (%lld / %lld per image), grey RMS vs pattern %.2f DN, seams %lld cells, "
              "%lld checked, %.3f px RMS\n",
              n, from[0], from[1], rms, o.seams.seam_cells, o.seams.checked, o.seams.geometric_rms_px);
  CHECK(n > 10000);
  CHECK(from[0] > 1000 && from[1] > 1000);
  CHECK_EQUAL(0, wrong_source);
  CHECK(rms < 4.0);  // bilinear of a pattern sampled at ~1-2 cells per pixel, rounding to 8 bits
  CHECK(o.seams.checked > 20);
  CHECK(o.seams.geometric_rms_px < 0.3);  // the estimator's floor: 11x11 NCC of 8-bit patches

  // A DEM 10 cm too high: the two images disagree at the seam, and the check says so.
  const ortho::OrthoResult bad = ortho::makeOrthoimage(flatDem(0.10f), src, ortho::OrthoOptions{});
  // Expected: the ground moves by ~dz * (half the 60 cm base) / (1.5 m height) ~ 2 cm = 1 cell, ~1-2 px.
  std::printf("  DEM 10 cm too high: seams %.3f px RMS\n", bad.seams.geometric_rms_px);
  CHECK(bad.seams.geometric_rms_px > 0.8);
}

TEST(Orthoimage, PaintingOnlyTheMaskedCellsGivesTheirSameValues) {
  std::vector<ortho::OrthoSource> src = {{cv::Mat(), camera(-0.25, -0.3)}, {cv::Mat(), camera(0.25, 0.3)}};
  for (auto& s : src) s.grey = render(s.model);
  const DemGrid dem = flatDem(0.0f);
  ortho::OrthoOptions options;
  options.supersample = 2;
  const ortho::OrthoResult whole = ortho::makeOrthoimage(dem, src, options);
  std::vector<uint8_t> cells(dem.values.size(), 0);
  for (std::size_t i = 0; i < cells.size(); i += 3) cells[i] = 1;  // every third DEM cell
  options.cells = &cells;
  options.check_seams = false;
  const ortho::OrthoResult part = ortho::makeOrthoimage(dem, src, options);
  long long painted = 0;
  for (int r = 0; r < whole.image.rows; ++r) {
    for (int c = 0; c < whole.image.cols; ++c) {
      const bool wanted = cells[static_cast<std::size_t>(r / 2) * dem.cols + c / 2] != 0;
      CHECK_EQUAL(wanted ? whole.image.at<uint8_t>(r, c) : 0, part.image.at<uint8_t>(r, c));
      painted += wanted && part.image.at<uint8_t>(r, c) != 0;
    }
  }
  CHECK(painted > 10000);
  CHECK(whole.seams.checked > 20);
  CHECK_EQUAL(0, part.seams.checked);  // not checked
}

TEST(Orthoimage, ShiftBetweenOrthoimagesIsMeasured) {
  cv::Mat a(200, 200, CV_8U), b;
  for (int r = 0; r < a.rows; ++r)
    for (int c = 0; c < a.cols; ++c) a.at<uint8_t>(r, c) = static_cast<uint8_t>(std::clamp(pattern(r * 0.05, c * 0.05), 1.0, 255.0));
  // b(x, y) = a(x - 2, y + 1): b is a moved 2 cells east and 1 north.
  const cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, 2, 0, 1, -1);
  cv::warpAffine(a, b, m, a.size());
  double se = 0, ss = 0;
  const int tiles = ortho::orthoShift(a, b, cv::Mat(), 32, 4, se, ss);
  CHECK(tiles > 4);
  DOUBLES_EQUAL(2.0, se, 0.05);
  DOUBLES_EQUAL(-1.0, ss, 0.05);
}

TEST(Orthoimage, DemElevationIsBilinear) {
  DemGrid g = flatDem(0.0f);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) g.at(c, r) = static_cast<float>(0.5 * g.northOfRow(r) + 0.25 * g.eastOfCol(c));
  double z = 0;
  CHECK(ortho::demElevation(g, 3.013, -1.207, z));
  DOUBLES_EQUAL(0.5 * 3.013 + 0.25 * -1.207, z, 1e-6);
  CHECK(!ortho::demElevation(g, 9.0, 0.0, z));
  g.at(100, 100) = g.nodata;
  CHECK(!ortho::demElevation(g, g.northOfRow(100), g.eastOfCol(100), z));
}
