// The DEM registration (ground/traverse/DemRegistration.hpp) on synthetic DEMs with a known relative pose in
// all six parameters: site B's frame tilted against A's as two frames levelled by IMU attitudes with errors
// of 0.2 deg each are, on ground sloping at 10 deg. The levelled registration cannot fit that tilt, and its
// translation takes up what the slope makes of it; the registration that solves the tilt with the
// attitudes' prior recovers the pose within its own sigmas.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "ground/traverse/DemRegistration.hpp"
#include "ground/traverse/SiteProducts.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using namespace areomap::traverse;

namespace {

constexpr double kRegistrationTestPi = 3.14159265358979323846;
constexpr double kDeg = kRegistrationTestPi / 180.0;
constexpr double kCellM = 0.1;
constexpr double kRangeM = 12.0;  // each DEM covers this far from its site

// The ground in A's frame (elevation up): a 10 deg slope down to the north-east, swells of 0.3 m over 8-11 m
// and rocks 0.1-0.4 m high and 0.3-1 m across, so that the relief fixes x, y and heading as a real site's
// does. The rocks are kept in 2 m buckets, so that an elevation looks at the few near it.
class Ground {
 public:
  Ground() {
    std::mt19937 rng(35);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int k = 0; k < 500; ++k) {
      const Rock r{kWestM + kSpanM * u(rng), kWestM + kSpanM * u(rng), 0.1 + 0.3 * u(rng),
                   0.3 + 0.7 * u(rng)};
      bucket(r.x, r.y).push_back(r);
    }
  }
  double operator()(double x, double y) const {
    const double slope = std::tan(10.0 * kDeg);
    double e = -slope * (x + y) / std::sqrt(2.0) + 0.3 * std::sin(x / 1.7) * std::cos(y / 1.3 + 0.4);
    const int bx = cellOf(x), by = cellOf(y);
    for (int i = std::max(0, bx - 1); i <= std::min(kBuckets - 1, bx + 1); ++i) {
      for (int j = std::max(0, by - 1); j <= std::min(kBuckets - 1, by + 1); ++j) {
        for (const Rock& r : buckets_[static_cast<std::size_t>(i * kBuckets + j)]) {
          const double d2 = (x - r.x) * (x - r.x) + (y - r.y) * (y - r.y);
          if (d2 < 4.0 * r.r * r.r) e += r.h * std::exp(-d2 / (r.r * r.r));
        }
      }
    }
    return e;
  }

 private:
  struct Rock {
    double x, y, h, r;
  };
  static constexpr double kWestM = -15.0, kSpanM = 32.0, kBucketM = 2.0;
  static constexpr int kBuckets = 16;
  static int cellOf(double v) { return static_cast<int>(std::floor((v - kWestM) / kBucketM)); }
  std::vector<Rock>& bucket(double x, double y) {
    const int i = std::clamp(cellOf(x), 0, kBuckets - 1), j = std::clamp(cellOf(y), 0, kBuckets - 1);
    return buckets_[static_cast<std::size_t>(i * kBuckets + j)];
  }
  std::vector<std::vector<Rock>> buckets_ = std::vector<std::vector<Rock>>(kBuckets * kBuckets);
};

// A DEM about a site origin in its own frame: A's where `a_from_site` is the identity; every cell the
// elevation of the ground under it, found by Newton's method along the site frame's vertical.
SiteProducts siteOf(const char* id, const Ground& ground, const RelativePose& a_from_site) {
  SiteProducts s;
  s.id = id;
  DemGrid& g = s.dem;
  g.cell_m = kCellM;
  g.cols = g.rows = static_cast<int>(2.0 * kRangeM / kCellM);
  g.east0_m = -kRangeM;
  g.north0_m = kRangeM;
  g.values.assign(static_cast<std::size_t>(g.cols) * g.rows, g.nodata);
  const Eigen::Matrix3d r = a_from_site.rotation();
  for (int row = 0; row < g.rows; ++row) {
    for (int col = 0; col < g.cols; ++col) {
      const double x = g.northOfRow(row), y = g.eastOfCol(col);
      if (std::hypot(x, y) > kRangeM) continue;
      double z = 0.0;  // the site point (x, y, z) lies on the ground: f(z) = p_a.z + e(p_a.x, p_a.y) = 0
      for (int it = 0; it < 4; ++it) {
        const Eigen::Vector3d p = a_from_site.toA(Eigen::Vector3d(x, y, z));
        const double h = 1e-3;
        const double f = p.z() + ground(p.x(), p.y());
        const double gx = (ground(p.x() + h, p.y()) - ground(p.x() - h, p.y())) / (2 * h);
        const double gy = (ground(p.x(), p.y() + h) - ground(p.x(), p.y() - h)) / (2 * h);
        z -= f / (r(2, 2) + gx * r(0, 2) + gy * r(1, 2));
      }
      g.at(col, row) = static_cast<float>(-z);
    }
  }
  return s;
}

struct Errors {
  double xy_m, z_m, heading_deg, tilt_deg;
};

Errors errorsOf(const RelativePose& p, const RelativePose& truth) {
  return {(p.translation_m - truth.translation_m).head<2>().norm(),
          std::fabs(p.translation_m.z() - truth.translation_m.z()),
          std::fabs(p.heading_rad - truth.heading_rad) / kDeg, (p.tilt_rad - truth.tilt_rad).norm() / kDeg};
}

}  // namespace

TEST_GROUP(DemRegistration){};

TEST(DemRegistration, SolvesTheRelativeTiltOfTwoFramesLevelledByTheirAttitudes) {
  // B 9 m from A, turned 25 deg; its frame tilted 0.25 and -0.2 deg about A's x and y (two attitudes with
  // 0.2 deg errors each give such a tilt: the prior's sigma is their root sum).
  RelativePose truth;
  truth.translation_m = Eigen::Vector3d(6.5, 6.0, 0.0);
  truth.heading_rad = 25.0 * kDeg;
  truth.tilt_rad = Eigen::Vector2d(0.25, -0.2) * kDeg;
  const Ground ground;
  truth.translation_m.z() = -ground(6.5, 6.0);  // B's origin on the ground
  const SiteProducts a = siteOf("A", ground, RelativePose{});
  const SiteProducts b = siteOf("B", ground, truth);
  // The odometry's pose: 0.6 m and 2 deg off, levelled.
  RelativePose apriori = shiftedPose(truth, 0.45, -0.4, 2.0 * kDeg);
  apriori.tilt_rad.setZero();
  apriori.translation_m.z() += 0.2;

  RegistrationParams levelled;
  RegistrationParams tilted;
  tilted.tilt_sigma_rad = std::sqrt(2.0) * 0.2 * kDeg;
  const DemRegistration g4 = registerDems(a, b, apriori, levelled);
  const DemRegistration g6 = registerDems(a, b, apriori, tilted);
  const Errors e4 = errorsOf(g4.a_from_b, truth), e6 = errorsOf(g6.a_from_b, truth);
  std::printf("\n  levelled: %s, %.4f m xy, %.4f m z, %.4f deg, tilt %.4f deg off (rms %.4f m)\n",
              registrationStatusName(g4.status), e4.xy_m, e4.z_m, e4.heading_deg, e4.tilt_deg, g4.rms_m);
  std::printf(
      "  tilt solved: %s, %.4f m xy, %.4f m z, %.4f deg, tilt %.4f deg off (rms %.4f m; sigma %.4f m, "
      "%.4f deg heading, %.4f %.4f deg tilt)\n",
      registrationStatusName(g6.status), e6.xy_m, e6.z_m, e6.heading_deg, e6.tilt_deg, g6.rms_m, g6.sigma[0],
      g6.sigma[3] / kDeg, g6.sigma[4] / kDeg, g6.sigma[5] / kDeg);
  CHECK(g6.status == RegistrationStatus::kOk);
  // Noise-free DEMs: what is left is the bilinear resampling of 10 cm cells, millimetres in height.
  // The tilt within a tenth of itself and the translation within a fifth of a cell.
  CHECK(e6.tilt_deg < 0.1 * truth.tilt_rad.norm() / kDeg);
  CHECK(e6.xy_m < 0.2 * kCellM);
  CHECK(e6.z_m < 0.2 * kCellM);
  CHECK(e6.heading_deg < 0.02);
  // The sigmas: the tilt's below its prior's (the DEMs, not the prior, bound it).
  CHECK(g6.sigma[4] > 0.0 && g6.sigma[4] < 0.5 * tilted.tilt_sigma_rad);
  CHECK(g6.sigma[5] > 0.0 && g6.sigma[5] < 0.5 * tilted.tilt_sigma_rad);
  // The levelled registration leaves the tilt in its differences and its translation.
  CHECK(e4.tilt_deg > 0.9 * truth.tilt_rad.norm() / kDeg);
  CHECK(g4.rms_m > 3.0 * g6.rms_m);
  CHECK(e4.z_m + e4.xy_m > 3.0 * (e6.z_m + e6.xy_m));
}

TEST(DemRegistration, AnInverseAndATurnKeepTheTilt) {
  RelativePose p;
  p.translation_m = Eigen::Vector3d(3.0, -2.0, 0.4);
  p.heading_rad = 0.7;
  p.tilt_rad = Eigen::Vector2d(0.004, -0.006);
  const Eigen::Vector3d x(1.0, 2.0, -0.5);
  // The inverse maps back.
  CHECK((p.inverse().toA(p.toA(x)) - x).norm() < 1e-12);
  // relativePoseOf takes a rotation apart into the same tilt and heading.
  const RelativePose q = relativePoseOf(p.rotation(), p.translation_m);
  CHECK((q.tilt_rad - p.tilt_rad).norm() < 1e-12);
  DOUBLES_EQUAL(p.heading_rad, q.heading_rad, 1e-12);
  // A turn about A's axes: the rotation exp([omega]x) R.
  const Eigen::Vector3d omega(0.002, -0.001, 0.01);
  const RelativePose t = turnedPose(p, omega);
  const Eigen::Matrix3d expected = Eigen::AngleAxisd(omega.norm(), omega.normalized()) * p.rotation();
  CHECK((t.rotation() - expected).norm() < 1e-12);
  // turnJacobian against a numerical derivative.
  const Eigen::Vector3d rb = p.rotation() * x;
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d w = Eigen::Vector3d::Zero();
    w[k] = 1e-7;
    const Eigen::Vector3d numeric = (turnedPose(p, w).rotation() * x - rb) / 1e-7;
    CHECK((numeric - turnJacobian(rb).col(k)).norm() < 1e-6);
  }
}
