#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Dense>

#include "ground/traverse/PatchWarp.hpp"

#include "CppUTest/TestHarness.h"

using namespace areomap::traverse;

namespace {

// A surface given by a function of I's pixel, counting its calls.
template <typename F>
class FunctionSurface : public PatchSurface {
 public:
  explicit FunctionSurface(F f) : f_(f) {}
  bool map(const Eigen::Vector2d& i_px, Eigen::Vector2d& j_px) const override {
    ++calls;
    return f_(i_px, j_px);
  }
  mutable int calls = 0;

 private:
  F f_;
};

constexpr int kHalf = 7;
constexpr int kSamples = (2 * kHalf + 1) * (2 * kHalf + 1);

// The largest distance between the offsets of a lattice and those of every sample cast.
template <typename F>
double worstAgainstEveryCast(F f, const Eigen::Vector2d& i_px, const Eigen::Matrix2d& mi, double tolerance_px,
                             int& casts) {
  FunctionSurface<F> surface(f);
  Eigen::Vector2d centre;
  CHECK(surface.map(i_px, centre));
  std::vector<Eigen::Vector2d> exact(kSamples), lattice(kSamples);
  int every = 0;
  surfaceOffsets(surface, i_px, centre, mi, Eigen::Matrix2d::Identity(), kHalf, 0.0, exact, &every);
  CHECK_EQUAL(kSamples, every);
  surfaceOffsets(surface, i_px, centre, mi, Eigen::Matrix2d::Identity(), kHalf, tolerance_px, lattice,
                 &casts);
  double worst = 0.0;
  for (int k = 0; k < kSamples; ++k) worst = std::max(worst, (exact[k] - lattice[k]).norm());
  return worst;
}

}  // namespace

TEST_GROUP(PatchWarp){};

// A smooth warp (a perspective-like quadratic of the pixel) is interpolated from a lattice within the
// tolerance with a fraction of the casts; a surface with an edge inside the patch (a step of 3 px in J)
// is cast at every sample, so its offsets are the exact ones.
TEST(PatchWarp, ALatticeWhereTheSurfaceIsSmoothEveryRayAtAnEdge) {
  const Eigen::Vector2d i_px(200.0, 150.0);
  const Eigen::Matrix2d mi = (Eigen::Matrix2d() << 1.6, 0.3, -0.2, 2.1).finished();
  auto smooth = [](const Eigen::Vector2d& p, Eigen::Vector2d& j) {
    const Eigen::Vector2d d = p - Eigen::Vector2d(200.0, 150.0);
    j = Eigen::Vector2d(50.0, 60.0) + 0.6 * d + 2e-4 * Eigen::Vector2d(d.x() * d.y(), d.squaredNorm());
    return true;
  };
  const double tolerance = 0.05;
  int casts = 0;
  const double smooth_worst = worstAgainstEveryCast(smooth, i_px, mi, tolerance, casts);
  CHECK_TEXT(smooth_worst <= tolerance, std::to_string(smooth_worst).c_str());
  CHECK(casts < kSamples / 2);
  // The same warp with its curvature 40 times stronger: the lattices disagree and every ray is cast.
  auto curved = [](const Eigen::Vector2d& p, Eigen::Vector2d& j) {
    const Eigen::Vector2d d = p - Eigen::Vector2d(200.0, 150.0);
    j = Eigen::Vector2d(50.0, 60.0) + 0.6 * d + 8e-3 * Eigen::Vector2d(d.x() * d.y(), d.squaredNorm());
    return true;
  };
  const double curved_worst = worstAgainstEveryCast(curved, i_px, mi, tolerance, casts);
  CHECK(curved_worst <= tolerance);
  CHECK(casts > kSamples);
  // A step edge across the patch (an occluding ridge) between lattice nodes.
  auto edge = [](const Eigen::Vector2d& p, Eigen::Vector2d& j) {
    j = 0.6 * p + Eigen::Vector2d(p.x() > 204.5 ? 3.0 : 0.0, 0.0);
    return true;
  };
  CHECK_EQUAL(0.0, worstAgainstEveryCast(edge, i_px, mi, tolerance, casts));
  CHECK(casts > kSamples);
  // A sample the surface does not map (its ray leaves the DEM): every ray cast, that one affine.
  auto holed = [](const Eigen::Vector2d& p, Eigen::Vector2d& j) {
    j = 0.6 * p;
    return p.y() < 160.0;
  };
  CHECK_EQUAL(0.0, worstAgainstEveryCast(holed, i_px, mi, tolerance, casts));
  CHECK(casts > kSamples);
}
