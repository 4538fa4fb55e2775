// firmware_core/camera/Binning.hpp: the binning factor, and the binned model against the definition of the
// binned pixel frame (x_b = (x + 0.5) / b - 0.5) applied to the full-resolution projection, on CAHV,
// CAHVOR and every CAHVORE kind.
#include <cmath>
#include <cstdio>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/camera/Binning.hpp"
#include "firmware_core/camera/CahvInternal.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "tests/firmware_core/camera/TestModels.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

// Points seen by the model: rays through a grid of pixels over the whole image at 1.5 to 40 m.
template <class Visit>
void forPointsSeen(const CameraModel& m, Visit visit) {
  for (int32_t gy = 0; gy <= 8; ++gy) {
    for (int32_t gx = 0; gx <= 8; ++gx) {
      const Vec2 pixel(gx * (m.width - 1) / 8.0, gy * (m.height - 1) / 8.0);
      Vec3 origin, dir;
      if (!ok(unproject(m, pixel, origin, dir))) continue;
      visit(origin + (1.5 + 4.8 * ((gx + gy) % 9)) * dir);
    }
  }
}

}  // namespace

TEST_GROUP(Binning){};

// The smallest factor that brings both sides within the capacity: floor(side / b) <= capacity.
TEST(Binning, FactorIsTheSmallestThatFits) {
  LONGS_EQUAL(1, binningFactor(1024, 1024));
  LONGS_EQUAL(1, binningFactor(1, 1));
  LONGS_EQUAL(2, binningFactor(1025, 10));
  LONGS_EQUAL(2, binningFactor(1288, 968));
  LONGS_EQUAL(2, binningFactor(2049, 1536));  // floor(2049 / 2) = 1024
  LONGS_EQUAL(3, binningFactor(2050, 10));
  LONGS_EQUAL(5, binningFactor(5120, 3840));
  LONGS_EQUAL(kMaxBinning, binningFactor(kMaxBinnedSourceWidth, kMaxBinnedSourceHeight));
  LONGS_EQUAL(kMaxBinning + 1, binningFactor(kMaxBinnedSourceWidth + 1, 10));
  LONGS_EQUAL(kMaxBinning + 1, binningFactor(10, kMaxBinnedSourceHeight + 1));
  // Against the definition, by search, over every side up to 20000 px.
  for (int32_t n = 1; n <= 20000; n += 7) {
    int32_t b = 1;
    while (n / b > kMaxImageWidth) ++b;
    if (binningFactor(n, 1) != b) FAIL("binningFactor differs from the smallest b with floor(n / b) <= cap");
  }
}

// Projecting with the binned model equals binning the full-resolution projection, to 1e-9 px, for every
// factor up to kMaxBinning and every model type; the CAHV centres and scales follow (hc - o) / b, hs / b.
TEST(Binning, BinnedModelProjectsAsTheBinnedPixelFrame) {
  CameraModel cahv = test::navcamLike();
  cahv.type = CameraType::kCahv;
  double worst = 0.0;
  int32_t checked = 0;
  auto check = [&](const CameraModel& full) {
    const CahvInternal in = cahvInternal(full);
    for (int32_t b = 2; b <= kMaxBinning; ++b) {
      const CameraModel binned = binnedModel(full, b);
      LONGS_EQUAL(full.width / b, binned.width);
      LONGS_EQUAL(full.height / b, binned.height);
      const CahvInternal ib = cahvInternal(binned);
      const double o = 0.5 * (b - 1);
      DOUBLES_EQUAL((in.hc_px - o) / b, ib.hc_px, 1e-9);
      DOUBLES_EQUAL((in.vc_px - o) / b, ib.vc_px, 1e-9);
      DOUBLES_EQUAL(in.hs_px / b, ib.hs_px, 1e-9);
      DOUBLES_EQUAL(in.vs_px / b, ib.vs_px, 1e-9);
      forPointsSeen(full, [&](const Vec3& point) {
        Vec2 x, xb;
        CHECK(ok(project(full, point, x)));
        CHECK(ok(project(binned, point, xb)));
        const Vec2 expected = (x + Vec2(0.5, 0.5)) / b - Vec2(0.5, 0.5);
        worst = std::fmax(worst, (xb - expected).cwiseAbs().maxCoeff());
        ++checked;
      });
      // Back: the full-resolution model of the binned one is the original (projection to 1e-9 px).
      const CameraModel back = unbinnedModel(binned, b, full.width, full.height);
      LONGS_EQUAL(full.width, back.width);
      forPointsSeen(full, [&](const Vec3& point) {
        Vec2 x, xr;
        CHECK(ok(project(full, point, x)));
        CHECK(ok(project(back, point, xr)));
        worst = std::fmax(worst, (xr - x).cwiseAbs().maxCoeff());
      });
    }
  };
  check(cahv);
  for (const test::NamedModel& n : test::syntheticModels()) check(n.model);
  std::printf("binned models: %d projections, worst |binned model - binned projection| %.3g px\n", checked,
              worst);
  CHECK(checked > 7 * 7 * 50);
  CHECK(worst < 1e-9);
}

// Full-resolution position of a binned pixel: the centre of the b x b block it averages.
TEST(Binning, FullResolutionPositionIsTheBlockCentre) {
  for (int32_t b = 1; b <= kMaxBinning; ++b) {
    for (int32_t xb = 0; xb < 5; ++xb) {
      double mean = 0.0;
      for (int32_t k = 0; k < b; ++k) mean += xb * b + k;
      DOUBLES_EQUAL(mean / b, fullResolutionPx(xb, b), 1e-12);
    }
  }
}
