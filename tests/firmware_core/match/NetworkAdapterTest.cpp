#include <cmath>
#include <cstdio>
#include <vector>

#include "firmware_core/match/NetworkAdapter.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/match/SyntheticStereo.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {
PanoramaMatcher g_panorama;
NetworkAdapter g_adapter;
Network g_network;
}  // namespace

TEST_GROUP(NetworkAdapter){};

// Two pairs enter the network as they arrive: every matcher observation becomes a network observation in
// ideal pixels that the a-priori camera reproduces (collinearity of the ground-plane truth within 1 px, the
// models being exact here), with zero heap.
TEST(NetworkAdapter, EveryTieEntersTheNetworkInIdealPixels) {
  const test::StereoScene a = test::makeStereoScene(256, 0.0, 0.7, 9);
  const test::StereoScene b = test::makeStereoScene(256, 0.5, 0.7, 9);
  g_panorama.reset();
  g_adapter.reset();
  g_network.clear();
  uint64_t heap = 0;
  int32_t failed_total = 0;
  for (const test::StereoScene* s : {&a, &b}) {
    const ImageView l = s->leftView(), r = s->rightView();
    PairTieReport report;
    HeapAllocationScope scope;
    CHECK(ok(g_panorama.addPair(l, &r, s->left, &s->right, report)));
    int32_t failed = 0;
    CHECK(ok(g_adapter.syncPair(g_panorama, 0, 0, s->left, &s->right, g_network, failed)));
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
    CHECK_EQUAL(g_adapter.networkImage(t.image), o.image);
    // The truth surface point of the tie: the first observation's ray on the ground plane.
    const TieObservation& first = g_panorama.observations()[g_network.point(o.point).obs[0]];
    const test::StereoScene& s0 = first.image / 2 == 0 ? a : b;
    Vec3 ground;
    CHECK(test::groundPoint(first.image % 2 == 0 ? s0.left : s0.right, Vec2(first.sample_px, first.line_px), ground));
    Vec2 px;
    CHECK(ok(collinearity(im.io, im.center_m, im.m, ground, px)));
    within += (px - o.ideal_px).norm() <= 1.0 ? 1 : 0;
    inter += t.kind == TieKind::kInter ? 1 : 0;
  }
  std::printf("adapter: %d images, %d points, %d observations (%d inter), %d within 1 px of the truth collinearity\n",
              g_network.imageCount(), g_network.pointCount(), g_network.observationCount(), inter, within);
  CHECK(inter >= 20);
  CHECK(within >= 0.98 * g_network.observationCount());
}
