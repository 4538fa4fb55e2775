#include <cmath>
#include <cstdio>

#include "firmware_core/camera/RayIntersection.hpp"
#include "firmware_core/dem/CoarseDem.hpp"
#include "firmware_core/match/StereoMatcher.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/match/SyntheticStereo.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {
StereoWorkspace g_stereo;
StereoResult g_result;
CoarseDem g_dem;
}  // namespace

TEST_GROUP(CoarseDem){};

TEST(CoarseDem, GroundPlaneFromIntraTiesPredictsTheSurface) {
  const test::StereoScene scene = test::makeStereoScene(384);
  StereoParams params;
  params.grid_cell_px = 32;
  CHECK(matchStereoPair(scene.leftView(), scene.rightView(), scene.left, scene.right, params, g_stereo, g_result) ==
        Status::kOk);
  HeapAllocationScope scope;
  g_dem.reset(scene.left.c);
  for (int32_t i = 0; i < g_result.tie_count; ++i) {
    Vec3 p;
    double miss = 0.0;
    if (triangulateMidpoint(scene.left, scene.right, g_result.ties[i].left_px, g_result.ties[i].right_px, p, miss) ==
        Status::kOk) {
      (void)g_dem.addPoint(p);
    }
  }
  const int32_t valid = g_dem.finish();
  // The surface is Z = 0: every valid cell and every ray intersection must agree with it.
  double worst_cell = 0.0;
  for (int32_t r = 0; r < CoarseDem::cells(); ++r) {
    for (int32_t c = 0; c < CoarseDem::cells(); ++c) {
      double z;
      if (g_dem.cellValue(r, c, z)) worst_cell = std::fmax(worst_cell, std::fabs(z));
    }
  }
  double worst_ray = 0.0;
  int32_t hits = 0;
  for (int32_t y = 100; y < 384; y += 40) {
    for (int32_t x = 20; x < 384; x += 40) {
      Vec3 o, d, p, truth;
      CHECK(unproject(scene.left, Vec2(x, y), o, d) == Status::kOk);
      if (!test::groundPoint(scene.left, Vec2(x, y), truth)) continue;
      if (g_dem.intersectRay(o, d, p) != Status::kOk) continue;
      ++hits;
      worst_ray = std::fmax(worst_ray, (p - truth).norm());
    }
  }
  CHECK_EQUAL(0u, scope.allocations());
  std::printf("coarse dem: %d points, %d measured cells, %d valid after filling; worst cell |z| %.3f m; "
              "%d ray hits, worst 3-D error %.3f m\n",
              g_dem.pointCount(), g_dem.measuredCells(), valid, worst_cell, hits, worst_ray);
  CHECK(g_dem.measuredCells() >= 20);
  CHECK(worst_cell < 0.02);
  CHECK(hits >= 40);
  CHECK(worst_ray < 0.1);
}
