// CrossSiteMatcher on a synthetic two-site scene: textured level ground (the matcher's test scene texture,
// SyntheticStereo.hpp), site A at the traverse origin, site B 15.8 m away turned 30 degrees, each with one
// camera looking at the same ground from opposite sides (7-9 m). Each site keeps its image and a flat DEM in
// its own frame; A's candidates are ground points it sees. Under the true pose every tie must land on the
// candidate's true pixel in B; under a pose off by 0.1 m and 0.3 degrees (what a registration leaves, 4-5 px
// here) the ties must still land on the true pixels, not on the predictions.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>

#include "SyntheticStereo.hpp"
#include "firmware_core/match/CrossSiteMatcher.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

constexpr double kXsPi = 3.14159265358979323846;
constexpr int32_t kXsSize = 256;

// The image of a camera (traverse frame) of the level ground Z = 0, 4 x 4 supersampled; the texture's
// features are 7-90 cm at scale 6, a quarter of that at scale 1.5.
void renderGround(const CameraModel& model, uint8_t* pixels, double scale) {
  for (int32_t y = 0; y < kXsSize; ++y) {
    for (int32_t x = 0; x < kXsSize; ++x) {
      double sum = 0.0;
      for (int32_t sy = 0; sy < 4; ++sy) {
        for (int32_t sx = 0; sx < 4; ++sx) {
          Vec3 o, d;
          const Vec2 px(x - 0.375 + 0.25 * sx, y - 0.375 + 0.25 * sy);
          if (!ok(unproject(model, px, o, d)) || d.z() <= 1e-6) continue;
          const Vec3 p = o + (-o.z() / d.z()) * d;
          sum += test::groundTexture(p.x() / scale, p.y() / scale, 7u);
        }
      }
      pixels[y * kXsSize + x] = static_cast<uint8_t>(std::lround(sum / 16.0));
    }
  }
}

// The model moved into a site frame: X_site = R^T (X_traverse - t).
CameraModel intoSite(const CameraModel& m, const LevelledPose& traverse_from_site) {
  const Mat3 rt = traverse_from_site.rotation().transpose();
  CameraModel s = m;
  s.c = rt * (m.c - traverse_from_site.translation_m);
  s.a = rt * m.a;
  s.h = rt * m.h;
  s.v = rt * m.v;
  return s;
}

void flatDem(CoarseDem& dem) {
  dem.reset(Vec3::Zero());
  for (double x = -30.0; x <= 30.0; x += 0.5)
    for (double y = -30.0; y <= 30.0; y += 0.5) (void)dem.addPoint(Vec3(x, y, 0.0));
  (void)dem.finish();
}

struct TwoSites {
  std::unique_ptr<CrossSiteRecord> a{new CrossSiteRecord}, b{new CrossSiteRecord};
  std::unique_ptr<uint8_t[]> image_a{new uint8_t[kXsSize * kXsSize]}, image_b{new uint8_t[kXsSize * kXsSize]};
  LevelledPose b_pose;  // traverse_from_site of B = A from B (A is the traverse frame)
  CameraModel camera_b;  // traverse frame

  explicit TwoSites(double texture_scale = 6.0) {
    b_pose.translation_m = Vec3(13.0, 9.0, 0.0);
    b_pose.heading_rad = 30.0 * kXsPi / 180.0;
    const double f = 0.5 * kXsSize / std::tan(30.0 * kXsPi / 180.0);
    const CameraModel camera_a = test::mastCamera(Vec3(0.0, 0.0, -3.0), std::atan2(5.0, 7.0), 0.33, f, kXsSize);
    camera_b = test::mastCamera(Vec3(13.0, 9.0, -3.0), std::atan2(-4.0, -6.0), 0.39, f, kXsSize);
    renderGround(camera_a, image_a.get(), texture_scale);
    renderGround(camera_b, image_b.get(), texture_scale);
    a->reset();
    b->reset();
    const PhotogrammetricCamera unused;
    CHECK(a->keepImage(ImageView{image_a.get(), kXsSize, kXsSize, kXsSize}, 0, camera_a, unused));
    CHECK(b->keepImage(ImageView{image_b.get(), kXsSize, kXsSize, kXsSize}, 0, intoSite(camera_b, b_pose),
                       unused));
    flatDem(a->dem());
    flatDem(b->dem());
    // A's candidates: ground points A sees, one per grid cell.
    for (double x = 1.0; x <= 15.0; x += 0.37) {
      for (double y = -3.0; y <= 13.0; y += 0.41) {
        CrossSiteCandidate c;
        c.xyz_m = Vec3(x, y, 0.0);
        c.observation_count = 2;
        Vec2 px;
        if (!ok(project(camera_a, c.xyz_m, px)) || px.x() < 20 || px.y() < 20 || px.x() > kXsSize - 20 ||
            px.y() > kXsSize - 20) {
          continue;
        }
        (void)a->offerCandidate(0, px, c);
      }
    }
  }
};

// Ties under `pose`: how many, and the largest distance of a tie from its candidate's true pixel in B.
void matchUnder(TwoSites& s, const LevelledPose& pose, int32_t& count, double& worst_px, double& rms_px,
                CrossMatchCounts& counts) {
  std::unique_ptr<CrossSiteMatcher> matcher(new CrossSiteMatcher);
  std::unique_ptr<RoverCrossTie[]> ties(new RoverCrossTie[kMaxCrossSiteTiesPerLeg]);
  const auto t0 = std::chrono::steady_clock::now();
  matcher->match(*s.a, *s.b, pose, CrossMatchParams{}, ties.get(), kMaxCrossSiteTiesPerLeg, count, counts);
  std::printf("\ncross-site matching: %.4f s for %d predictions (refused: %d low NCC, %d ambiguous, %d peak on "
              "the edge, %d scale, %d grazing, %d warp, %d off the DEM)\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
              static_cast<int>(counts.predicted), static_cast<int>(counts.low_ncc),
              static_cast<int>(counts.ambiguous), static_cast<int>(counts.edge_peak),
              static_cast<int>(counts.scale_gate), static_cast<int>(counts.grazing),
              static_cast<int>(counts.warp_failed), static_cast<int>(counts.outside));
  worst_px = 0.0;
  double sum2 = 0.0;
  for (int32_t t = 0; t < count; ++t) {
    Vec2 truth;
    CHECK(ok(project(s.camera_b, s.a->candidate(ties[t].candidate).xyz_m, truth)));
    worst_px = std::fmax(worst_px, (ties[t].matcher_px - truth).norm());
    sum2 += (ties[t].matcher_px - truth).squaredNorm();
  }
  rms_px = count > 0 ? std::sqrt(sum2 / count) : 0.0;
}

}  // namespace

TEST_GROUP(CrossSiteMatcher){};

TEST(CrossSiteMatcher, TiesLandOnTheTruePixelsOfTheOtherSite) {
  TwoSites s;
  CHECK_TRUE(s.a->candidateCount() >= 12);
  int32_t count = 0;
  double worst = 0.0, rms = 0.0;
  CrossMatchCounts counts;
  matchUnder(s, s.b_pose, count, worst, rms, counts);
  std::printf("\ncross-site matcher, true pose: %d candidates, %d predicted, %d ties, RMS %.3f px, worst %.3f px\n",
              static_cast<int>(s.a->candidateCount()), static_cast<int>(counts.predicted),
              static_cast<int>(count), rms, worst);
  // Every prediction that passes the geometric gates is matched; a tie places the candidate, not the
  // integer pixel its template is centred on (that alone would leave 0.41 px RMS).
  const int32_t searched = counts.predicted - counts.scale_gate - counts.warp_failed;
  CHECK_TRUE(searched >= 12);
  CHECK_TRUE(count >= searched * 9 / 10);
  CHECK_TRUE(rms < 0.2);
  CHECK_TRUE(worst < 0.5);
}

TEST(CrossSiteMatcher, AnOffsetPoseStillFindsTheTruePixels) {
  TwoSites s;
  LevelledPose off = s.b_pose;
  off.translation_m += Vec3(0.08, -0.06, 0.0);
  off.heading_rad += 0.3 * kXsPi / 180.0;
  int32_t count = 0;
  double worst = 0.0, rms = 0.0;
  CrossMatchCounts counts;
  matchUnder(s, off, count, worst, rms, counts);
  std::printf("\ncross-site matcher, offset pose: %d ties of %d predictions, RMS %.3f px, worst %.3f px\n",
              static_cast<int>(count), static_cast<int>(counts.predicted), rms, worst);
  const int32_t searched = counts.predicted - counts.scale_gate - counts.warp_failed;
  CHECK_TRUE(count >= searched * 2 / 3);  // the wrong pose warps the templates a little wrongly
  CHECK_TRUE(rms < 0.3);
  CHECK_TRUE(worst < 0.6);
}

// Ground textured finer than B's pixels resolve, where A sees it finer than B: a template that samples A only
// at B's pixel centres aliases (its NCC with B's image, which averages each pixel's footprint, drops; 7 ties
// of 18 searched that way), the mean over each footprint keeps the ties.
TEST(CrossSiteMatcher, AFinerViewIsAveragedOverEachFootprint) {
  TwoSites s(1.5);
  int32_t count = 0;
  double worst = 0.0, rms = 0.0;
  CrossMatchCounts counts;
  matchUnder(s, s.b_pose, count, worst, rms, counts);
  const int32_t searched = counts.predicted - counts.scale_gate - counts.warp_failed;
  std::printf("\ncross-site matcher, fine texture: %d ties of %d searched, RMS %.3f px, worst %.3f px\n",
              static_cast<int>(count), static_cast<int>(searched), rms, worst);
  CHECK_TRUE(count >= searched * 2 / 3);
  CHECK_TRUE(rms < 0.3);
}
