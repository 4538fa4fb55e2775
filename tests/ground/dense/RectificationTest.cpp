// Rectification of an unrectified CAHVOR pair (toe-in, tilt, distortion) with its models: rows become
// epipolar lines, the maps invert originalToRectified, and intersecting rectified matches through the
// rectified models gives back the 3-D point. Truth: points projected through the original models.
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <opencv2/core.hpp>

#include "ground/dense/Rectification.hpp"
#include "ground/dense/Triangulation.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

// A CAHVOR camera at `c` looking along yaw/pitch (site frame: x north, y east, z down), 1024x1024,
// f = 1236 px, principal point off centre, distortion axis tilted 0.3 degrees.
CameraModel camera(const Vec3& c, double yaw, double pitch) {
  const Vec3 a(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw), std::sin(pitch));  // z down: looks down
  const Vec3 up(0, 0, -1);
  const Vec3 hr = a.cross(up).normalized();  // image right
  const Vec3 vp = a.cross(hr).normalized();  // image down
  CameraModel m;
  m.type = CameraType::kCahvor;
  m.c = c;
  m.a = a;
  m.h = 1236.0 * hr + 515.0 * a;
  m.v = 1236.0 * vp + 508.0 * a;
  m.o = (a + 0.005 * hr).normalized();
  m.r = Vec3(0.0, 0.006, -0.004);
  m.width = 1024;
  m.height = 1024;
  return m;
}

}  // namespace

TEST_GROUP(Rectification){};

TEST(Rectification, RowsAreEpipolarAndMatchesIntersect) {
  const double toe = 0.5 * M_PI / 180.0, tilt = 26.0 * M_PI / 180.0;
  const CameraModel left = camera(Vec3(0.08, -0.10, -1.55), toe, tilt);
  const CameraModel right = camera(Vec3(0.08, 0.10, -1.55), -toe, tilt + 0.002);
  const dense::RectifiedPair rect = dense::rectifyPair(left, right);
  DOUBLES_EQUAL(0.20, rect.baseline_m, 1e-9);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double max_row = 0, max_map = 0, max_xyz = 0;
  int n = 0;
  for (int i = 0; i < 2000; ++i) {
    // A ground point 2-15 m ahead, within the view.
    const double range = 2.0 + 13.0 * u(rng), az = (u(rng) - 0.5) * 0.6;
    const Vec3 p(range * std::cos(az), range * std::sin(az), 0.3 * (u(rng) - 0.5));
    Vec2 lp, rp;
    if (project(left, p, lp) != Status::kOk || project(right, p, rp) != Status::kOk) continue;
    if (lp.x() < 20 || lp.y() < 20 || lp.x() > 1003 || lp.y() > 1003) continue;
    if (rp.x() < 20 || rp.y() < 20 || rp.x() > 1003 || rp.y() > 1003) continue;
    Vec2 lr, rr;
    CHECK(dense::originalToRectified(left, rect.left, lp, lr));
    CHECK(dense::originalToRectified(right, rect.right, rp, rr));
    max_row = std::max(max_row, std::fabs(lr.y() - rr.y()));
    CHECK(lr.x() - rr.x() > 0);  // positive disparity
    // The map at the rectified pixel (nearest) leads back near the original pixel.
    const int xi = static_cast<int>(std::lround(lr.x())), yi = static_cast<int>(std::lround(lr.y()));
    if (xi >= 0 && yi >= 0 && xi < 1024 && yi < 1024) {
      const cv::Vec2f m = rect.left_map.at<cv::Vec2f>(yi, xi);
      Vec2 back;
      CHECK(dense::originalToRectified(left, rect.left, Vec2(m[0], m[1]), back));
      max_map = std::max(max_map, (back - Vec2(xi, yi)).norm());
    }
    dense::CloudPoint cp;
    CHECK(dense::triangulate(rect.left, rect.right, lr, rr, 0.3, cp));
    max_xyz = std::max(max_xyz, (cp.site_m - p).norm());
    ++n;
  }
  std::printf("\n  rectification: %d points, max row difference %.2e px, max map round trip %.2e px, max 3-D error "
              "%.2e m, rotation into the common frame %.3f deg\n",
              n, max_row, max_map, max_xyz, rect.max_rotation_rad * 180 / M_PI);
  CHECK(n > 500);
  CHECK(max_row < 1e-6);
  CHECK(max_map < 1e-3);
  CHECK(max_xyz < 1e-6);
}

TEST(Rectification, DegeneratePairsAreRejected) {
  const CameraModel left = camera(Vec3(0, 0, -1.5), 0.0, 0.4);
  CameraModel same = left;
  CHECK_THROWS(std::invalid_argument, dense::rectifyPair(left, same));
  CameraModel ahead = left;
  ahead.c = left.c + 0.2 * left.a;  // baseline along the optical axis
  CHECK_THROWS(std::invalid_argument, dense::rectifyPair(left, ahead));
  CameraModel unsized = camera(Vec3(0, 0.2, -1.5), 0.0, 0.4);
  unsized.width = 0;
  CHECK_THROWS(std::invalid_argument, dense::rectifyPair(left, unsized));
}
