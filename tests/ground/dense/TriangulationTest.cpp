#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "ground/dense/Triangulation.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using namespace areomap::dense;

namespace {

// A CAHV camera at `c` looking north (A = +X), image right = east (+Y), image down = +Z; f = 1000 px,
// principal point (511.5, 511.5) of a 1024 x 1024 image.
CameraModel northCamera(const Vec3& c) {
  CameraModel m;
  m.type = CameraType::kCahv;
  m.c = c;
  m.a = Vec3(1, 0, 0);
  m.h = 1000.0 * Vec3(0, 1, 0) + 511.5 * m.a;
  m.v = 1000.0 * Vec3(0, 0, 1) + 511.5 * m.a;
  m.width = 1024;
  m.height = 1024;
  return m;
}

}  // namespace

TEST_GROUP(Triangulation){};

TEST(Triangulation, RecoversPointsAndPredictsTheirScatter) {
  const CameraModel l = northCamera(Vec3(0, -0.1, -1.5));
  const CameraModel r = northCamera(Vec3(0, 0.1, -1.5));
  const Vec3 truth(6.0, 0.7, 0.2);
  Vec2 pl, pr;
  CHECK(project(l, truth, pl) == Status::kOk);
  CHECK(project(r, truth, pr) == Status::kOk);
  CloudPoint p;
  CHECK(triangulate(l, r, pl, pr, 0.3, p));
  CHECK((p.site_m - truth).norm() < 1e-6);
  CHECK(p.residual_px < 1e-6);
  // Monte Carlo: pixel noise of 0.3 px; the empirical covariance matches the predicted one.
  std::mt19937 rng(9);
  std::normal_distribution<double> n(0.0, 0.3);
  const int trials = 2000;
  Vec3 mean = Vec3::Zero();
  std::vector<Vec3> samples;
  for (int i = 0; i < trials; ++i) {
    CloudPoint q;
    CHECK(triangulate(l, r, pl + Vec2(n(rng), n(rng)), pr + Vec2(n(rng), n(rng)), 0.3, q));
    samples.push_back(q.site_m);
    mean += q.site_m;
  }
  mean /= trials;
  Mat3 cov = Mat3::Zero();
  for (const Vec3& s : samples) cov += (s - mean) * (s - mean).transpose();
  cov /= trials - 1;
  std::printf("\nintersection at 6 m, b = 0.2 m, 0.3 px: sigma x %.4f/%.4f y %.4f/%.4f z %.4f/%.4f m "
              "(predicted/Monte Carlo)\n", std::sqrt(p.covariance_m2(0, 0)), std::sqrt(cov(0, 0)),
              std::sqrt(p.covariance_m2(1, 1)), std::sqrt(cov(1, 1)), std::sqrt(p.covariance_m2(2, 2)),
              std::sqrt(cov(2, 2)));
  for (int k = 0; k < 3; ++k) DOUBLES_EQUAL(std::sqrt(p.covariance_m2(k, k)), std::sqrt(cov(k, k)),
                                            0.1 * std::sqrt(p.covariance_m2(k, k)));
}

TEST(Triangulation, DisparityMapToCloudAndPly) {
  const CameraModel l = northCamera(Vec3(0, -0.1, -1.5));
  const CameraModel r = northCamera(Vec3(0, 0.1, -1.5));
  // Flat ground at Z = 0 seen by this rectified pair: below the horizon, d = f b / depth.
  cv::Mat disp(1024, 1024, CV_32FC1, cv::Scalar(NAN));
  for (int y = 600; y < 1024; y += 8) {
    for (int x = 0; x < 1024; x += 8) {
      const double depth = 1000.0 * 1.5 / (y - 511.5);
      disp.at<float>(y, x) = static_cast<float>(1000.0 * 0.2 / depth);
    }
  }
  disp.at<float>(10, 10) = -5.0f;  // a bad match: the rays diverge
  TriangulationStats st;
  const std::vector<CloudPoint> cloud = triangulateDisparity(l, r, disp, 0.3, 3, cv::Mat(), st);
  CHECK_EQUAL(st.matches - 1, st.triangulated);
  CHECK_EQUAL(1, st.rejected_geometry);
  double worst = 0.0;
  for (const CloudPoint& p : cloud) worst = std::max(worst, std::abs(p.site_m.z()));
  std::printf("\nflat ground: %lld points, largest |Z| %.2e m\n", st.triangulated, worst);
  CHECK(worst < 1e-4);  // float32 disparities
  CHECK_EQUAL(3 * 65536 + 600, cloud.front().line);  // lineId(3, 600), written out
  const std::string path = areomap::test::scratchDir("triangulation") + "/points.ply";
  writePly(path, cloud, "test");
  std::ifstream f(path, std::ios::binary);
  std::string header, line;
  while (std::getline(f, line)) {
    header += line + "\n";
    if (line == "end_header") break;
  }
  CHECK(header.find("element vertex " + std::to_string(cloud.size())) != std::string::npos);
  const std::streampos start = f.tellg();
  f.seekg(0, std::ios::end);
  CHECK_EQUAL(static_cast<long long>(cloud.size()) * (3 * 8 + 3 * 4 + 1 + 4),
              static_cast<long long>(f.tellg() - start));
  CHECK_THROWS(std::runtime_error, writePly("/nonexistent-dir/x.ply", cloud));
  // Read back: the same points, their per-axis sigmas and lines.
  const std::vector<CloudPoint> back = readPly(path);
  CHECK_EQUAL(cloud.size(), back.size());
  for (std::size_t i = 0; i < cloud.size(); i += 97) {
    CHECK(cloud[i].site_m == back[i].site_m);
    CHECK_EQUAL(cloud[i].line, back[i].line);
    DOUBLES_EQUAL(cloud[i].sigmaHeight_m(), back[i].sigmaHeight_m(), 1e-6 * cloud[i].sigmaHeight_m());
  }
  CHECK_THROWS(std::runtime_error, readPly("/nonexistent-dir/x.ply"));
}
