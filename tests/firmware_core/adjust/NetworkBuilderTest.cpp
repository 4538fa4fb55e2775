#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "firmware_core/adjust/NetworkBuilder.hpp"
#include "firmware_core/match/PanoramaMatcher.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/camera/TestModels.hpp"
#include "tests/firmware_core/match/SyntheticStereo.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {
PanoramaMatcher g_panorama;
CoarseDem g_dem;
NetworkBuilder g_builder;
Network g_network;
}  // namespace

TEST_GROUP(NetworkBuilder){};

// Two pairs enter the network as they arrive: every matcher observation becomes a network observation in
// ideal pixels that the a-priori camera reproduces (collinearity of the ground-plane truth within 1 px, the
// models being exact here), with zero heap.
TEST(NetworkBuilder, EveryMatcherTieEntersTheNetworkInIdealPixels) {
  const test::StereoScene a = test::makeStereoScene(256, 0.0, 0.7, 9);
  const test::StereoScene b = test::makeStereoScene(256, 0.5, 0.7, 9);
  g_panorama.reset();
  g_builder.reset();
  g_network.clear();
  uint64_t heap = 0;
  int32_t failed_total = 0;
  for (const test::StereoScene* s : {&a, &b}) {
    const ImageView l = s->leftView(), r = s->rightView();
    PairTieReport report;
    HeapAllocationScope scope;
    CHECK(ok(g_panorama.addPair(l, &r, s->left, &s->right, g_dem, report)));
    int32_t failed = 0;
    CHECK(ok(g_builder.syncPair(g_panorama.ties(), 0, 0, s->left, &s->right, g_network, failed)));
    heap += scope.allocations();
    failed_total += failed;
  }
  CHECK_EQUAL(0u, heap);
  CHECK_EQUAL(0, failed_total);
  CHECK_EQUAL(4, g_network.imageCount());
  CHECK_EQUAL(g_panorama.points().size(), g_network.pointCount());
  CHECK_EQUAL(g_panorama.observations().size(), g_network.observationCount());
  int32_t within = 0, inter = 0;
  for (int32_t k = 0; k < g_network.observationCount(); ++k) {
    const NetObservation& o = g_network.observation(k);
    const NetImage& im = g_network.image(o.image);
    const TieObservation& t = g_panorama.observations()[k];
    CHECK_EQUAL(g_builder.networkImage(t.image), o.image);
    // The truth surface point of the tie: the first observation's ray on the ground plane.
    const TieObservation& first = g_panorama.observations()[g_network.point(o.point).obs[0]];
    const test::StereoScene& s0 = first.image / 2 == 0 ? a : b;
    Vec3 ground;
    CHECK(test::groundPoint(first.image % 2 == 0 ? s0.left : s0.right, Vec2(first.sample_px, first.line_px),
                            ground));
    Vec2 px;
    CHECK(ok(collinearity(im.io, im.centre_m, im.m, ground, px)));
    within += (px - o.ideal_px).norm() <= 1.0 ? 1 : 0;
    inter += t.kind == TieKind::kInter ? 1 : 0;
  }
  std::printf(
      "network builder: %d images, %d points, %d observations (%d inter), %d within 1 px of the truth "
      "collinearity\n",
      g_network.imageCount(), g_network.pointCount(), g_network.observationCount(), inter, within);
  CHECK(inter >= 20);
  CHECK(within >= 0.98 * g_network.observationCount());
}

namespace {
TiePoint g_points[64];
TieObservation g_observations[512];
bool g_bad[512];
}  // namespace

// A tie list made by hand (no matcher): 3 pairs of CAHVOR cameras turned about a mast, 64 ground points,
// each observed where the true models put it, and two bad observations (an unknown point, an image of a pair
// not yet added). Pair by pair, the builder adds every new item once; each good observation becomes the
// ideal pixel that the photogrammetric camera's collinearity gives for the true point (the conversion's exact
// inverse, so to 1e-9 px), and the bad ones are counted, not added.
TEST(NetworkBuilder, HandMadeTieListEntersPairByPair) {
  const CameraModel base_left = test::navcamLike();
  const Vec3 h_dir = (base_left.h - base_left.a.dot(base_left.h) * base_left.a).normalized();
  const Vec3 mast(0.0, 0.0, -1.5);
  CameraModel models[3][2];
  for (int32_t j = 0; j < 3; ++j) {
    const Mat3 turn = rotationFromVector(Vec3(0.0, 0.0, 0.35 * j));  // pan about the mast (Z)
    const CameraModel left = movedModel(base_left, turn, mast + turn * (base_left.c - mast));
    models[j][0] = left;
    models[j][1] = movedModel(left, Mat3::Identity(), left.c + 0.2 * (turn * h_dir));
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.05, 0.95), range(3.0, 25.0);
  int32_t point_count = 0, observation_count = 0;
  Vec3 truth[64];
  NetworkBuilder& builder = g_builder;
  builder.reset();
  g_network.clear();
  for (int32_t j = 0; j < 3; ++j) {
    // New points seen from pair j's left image; observed in every image (of pairs 0..j) they project into.
    for (int32_t k = 0; k < 20 && point_count < 64; ++k) {
      Vec3 o, d;
      CHECK(ok(unproject(models[j][0], Vec2(u(rng) * 1024.0, u(rng) * 1024.0), o, d)));
      truth[point_count] = o + range(rng) * d;
      g_points[point_count].ground_m = truth[point_count] + Vec3(0.01, -0.02, 0.015);  // a-priori, off
      g_points[point_count].pair = j;
      ++point_count;
    }
    for (int32_t p = 0; p < point_count; ++p) {
      for (int32_t side = 0; side < 2; ++side) {
        Vec2 px;
        if (!ok(project(models[j][side], truth[p], px)) || px.x() < 0 || px.y() < 0 || px.x() > 1023 ||
            px.y() > 1023) {
          continue;
        }
        g_bad[observation_count] = false;
        TieObservation& t = g_observations[observation_count++];
        t.point = p;
        t.image = 2 * j + side;
        t.sample_px = px.x();
        t.line_px = px.y();
        t.kind = g_points[p].pair == j ? TieKind::kIntra : TieKind::kInter;
      }
    }
    g_bad[observation_count] = true;
    g_observations[observation_count++] = TieObservation{-5, 2 * j, 10.0, 10.0, TieKind::kInter, 0.9f};
    g_bad[observation_count] = true;
    g_observations[observation_count++] = TieObservation{0, 2 * j + 2, 10.0, 10.0, TieKind::kInter, 0.9f};
    const TieList list{g_points, point_count, g_observations, observation_count, j + 1};
    int32_t failed = 0;
    HeapAllocationScope scope;
    CHECK(ok(builder.syncPair(list, 0, 0, models[j][0], &models[j][1], g_network, failed)));
    CHECK_EQUAL(0u, scope.allocations());
    CHECK_EQUAL(2, failed);
    CHECK_EQUAL(2 * (j + 1), g_network.imageCount());
    CHECK_EQUAL(point_count, g_network.pointCount());
  }
  CHECK_EQUAL(observation_count - 6, g_network.observationCount());
  CHECK_EQUAL(-1, builder.networkImage(-1));
  CHECK_EQUAL(-1, builder.networkImage(6));
  double worst_px = 0.0;
  int32_t k = 0;
  for (int32_t i = 0; i < observation_count; ++i) {
    const TieObservation& t = g_observations[i];
    if (g_bad[i]) continue;
    const NetObservation& o = g_network.observation(k++);
    CHECK_EQUAL(builder.networkImage(t.image), o.image);
    const NetImage& im = g_network.image(o.image);
    Vec2 ideal;
    CHECK(ok(collinearity(im.io, im.centre_m, im.m, truth[t.point], ideal)));
    worst_px = std::fmax(worst_px, (ideal - o.ideal_px).norm());
  }
  for (int32_t p = 0; p < point_count; ++p)
    CHECK((g_network.point(p).xyz_m - g_points[p].ground_m).norm() == 0.0);
  std::printf("hand-made tie list: %d points, %d observations, worst ideal-pixel error %.2e px\n",
              point_count, g_network.observationCount(), worst_px);
  CHECK_EQUAL(g_network.observationCount(), k);
  CHECK(worst_px < 1e-9);
}
