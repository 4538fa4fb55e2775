// The hold-out check of the adjustment (ground/ties/HoldOutCheck.hpp) on one stereo pair alone, with
// synthetic truth: ties on a ground plane seen by a Navcam-like pair, Gaussian noise, a-priori cameras
// either exact or with the right camera turned by a few pixels, wrong ties mixed in, ties bunched in one
// corner. Over several seeds: the cameras the pass keeps are never farther from the truth (relative
// orientation, the only part the ties determine) than the a-priori ones beyond the noise of the ties, an
// a-priori error is corrected, wrong ties are found.
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "firmware_core/adjust/FastAdjuster.hpp"
#include "firmware_core/camera/Photogrammetric.hpp"
#include "ground/ties/HoldOutCheck.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

constexpr double kF = 1000.0;
constexpr int kW = 1280, kH = 960;

struct Scene {
  InteriorOrientation io;
  Vec3 c[2];
  Mat3 m[2];  // true
};

Scene navcamLike() {
  Scene s;
  s.io.f_px = kF;
  s.io.x0_px = 0.5 * (kW - 1);
  s.io.y0_px = 0.5 * (kH - 1);
  s.io.width = kW;
  s.io.height = kH;
  const double el = 30.0 * M_PI / 180.0;
  const Vec3 forward(std::cos(el), 0.0, std::sin(el));  // north and down (site Z down)
  const Vec3 x(0.0, 1.0, 0.0), z = -forward, y = z.cross(x);
  Mat3 m;
  m.row(0) = x.transpose();
  m.row(1) = y.transpose();
  m.row(2) = z.transpose();
  s.c[0] = Vec3(0.0, 0.0, -1.9);
  s.c[1] = s.c[0] + 0.42 * x;
  s.m[0] = m;
  s.m[1] = m;
  return s;
}

struct Options {
  int ties = 150;
  double noise_px = 0.1;
  double apriori_turn_px = 0.0;  // the right camera's a-priori rotation error
  double wrong_fraction = 0.0;   // ties with one observation 3-8 px off its epipolar line
  int corner_px = 0;             // > 0: every left observation within this of the lower-right corner
};

struct Outcome {
  HoldOutResult check;
  double apriori_error_px = 0.0;  // relative orientation error of the a-priori cameras, f x angle
  double final_error_px = 0.0;    // of the cameras the pass keeps
  int wrong_points = 0, wrong_found = 0, good_flagged = 0;
};

double relativeErrorPx(const Network& net, const Scene& s) {
  const Mat3 rel = net.image(1).m * net.image(0).m.transpose();
  const Mat3 truth = s.m[1] * s.m[0].transpose();
  return kF * rotationAngle(rel, truth);
}

Outcome runPair(const Options& o, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, o.noise_px);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const Scene s = navcamLike();
  Mat3 right_apriori = s.m[1];
  if (o.apriori_turn_px > 0.0) {
    const Vec3 axis = Vec3(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5).normalized();
    right_apriori = Eigen::AngleAxisd(o.apriori_turn_px / kF, axis).toRotationMatrix() * s.m[1];
  }
  auto net = std::make_unique<Network>();
  int32_t pair = -1;
  CHECK(ok(net->addPair(0, 0, s.io, s.c[0], s.m[0], &s.io, s.c[1], right_apriori, pair)));
  net->rig.use_gimbal = false;
  net->rig.base_m = s.m[0] * (s.c[1] - s.c[0]);
  Outcome out;
  std::vector<bool> wrong;
  while (static_cast<int>(wrong.size()) < o.ties) {
    const double span = o.corner_px > 0 ? o.corner_px : 1.0;
    const Vec2 px = o.corner_px > 0 ? Vec2(kW - 1 - span * unit(rng), kH - 1 - span * unit(rng))
                                    : Vec2(kW * unit(rng), kH * unit(rng));
    const Vec3 ray = s.m[0].transpose() * Vec3(px.x() - s.io.x0_px, -(px.y() - s.io.y0_px), -kF);
    if (ray.z() <= 1e-3) continue;  // above the horizon
    const Vec3 ground = s.c[0] + (-s.c[0].z() / ray.z()) * ray;
    Vec2 obs[2];
    bool inside = true;
    for (int k = 0; k < 2; ++k) {
      inside = inside && ok(collinearity(s.io, s.c[k], s.m[k], ground, obs[k])) && obs[k].x() >= 0 &&
               obs[k].x() < kW && obs[k].y() >= 0 && obs[k].y() < kH;
    }
    if (!inside) continue;
    const bool bad = unit(rng) < o.wrong_fraction;
    // Across the epipolar lines (rows here): a tie wrong along them is only a wrong depth, which no
    // geometry can find and which moves no camera.
    if (bad) obs[1].y() += (unit(rng) < 0.5 ? -1.0 : 1.0) * (3.0 + 5.0 * unit(rng));
    int32_t point = -1;
    CHECK(ok(net->addPoint(ground, point)));
    for (int k = 0; k < 2; ++k)
      CHECK(ok(
          net->addObservation(point, net->pair(pair).left + k, obs[k] + Vec2(noise(rng), noise(rng)), 0.3)));
    wrong.push_back(bad);
  }
  // As the pass: the robust adjustment's rejection, the check, the adjustment again, the verdict applied.
  auto adjuster = std::make_unique<FastAdjuster>();
  int32_t failed = 0;
  (void)net->triangulateAll(failed);
  FastAdjustResult result;
  CHECK(ok(adjuster->adjust(*net, FastAdjustOptions{}, result)));
  out.check = holdOutCheck(*net, FastAdjustOptions{});
  for (std::size_t p = 0; p < wrong.size(); ++p) {
    const NetPoint& point = net->point(static_cast<int32_t>(p));
    const bool flagged = net->observation(point.obs[0]).rejected || net->observation(point.obs[1]).rejected;
    out.wrong_points += wrong[p] ? 1 : 0;
    out.wrong_found += wrong[p] && flagged ? 1 : 0;
    out.good_flagged += !wrong[p] && flagged ? 1 : 0;
  }
  net->resetToApriori();
  out.apriori_error_px = relativeErrorPx(*net, s);
  (void)net->triangulateAll(failed);
  CHECK(ok(adjuster->adjust(*net, FastAdjustOptions{}, result)));
  (void)keepAprioriWhereRejected(*net, out.check);
  out.final_error_px = relativeErrorPx(*net, s);
  return out;
}

}  // namespace

TEST_GROUP(HoldOutCheck){};

// Exact a-priori cameras: whatever the verdict, the kept cameras stay within the ties' own noise of them
// (150 ties of 0.1 px determine the relative rotation to ~0.01 px; 0.05 px is five times that).
TEST(HoldOutCheck, ExactAprioriIsNotMadeWorse) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const Outcome o = runPair(Options{}, seed);
    CHECK(o.check.ran);
    CHECK(o.final_error_px <= 0.05);
  }
}

// A-priori right camera turned by 2 px: the adjustment is accepted and corrects it to a quarter or better
// (the vergence part of the relative rotation is weakly determined by ties alone: it mostly moves the
// points in depth).
TEST(HoldOutCheck, AprioriErrorIsCorrected) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    Options opt;
    opt.apriori_turn_px = 2.0;
    const Outcome o = runPair(opt, seed);
    CHECK(o.check.pairs.at(0).adjusted);
    CHECK(o.apriori_error_px > 1.5);
    CHECK(o.final_error_px <= 0.25 * o.apriori_error_px);
  }
}

// 10 % wrong ties (one observation 3-8 px off its epipolar line) on top of a 2 px a-priori error: nearly
// all are found, few good ones are lost, and the result is as good as without them.
TEST(HoldOutCheck, WrongTiesAreFound) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    Options opt;
    opt.apriori_turn_px = 2.0;
    opt.wrong_fraction = 0.1;
    const Outcome o = runPair(opt, seed);
    CHECK(o.wrong_points > 5);
    CHECK(o.wrong_found >= o.wrong_points - 1);
    CHECK(o.good_flagged <= 3);
    CHECK(o.check.pairs.at(0).adjusted);
    CHECK(o.final_error_px <= 0.25 * o.apriori_error_px);
  }
}

// Exact a-priori cameras and ties bunched in one corner of the image (the principal point's corner of a
// sensor tile), noisier, a few wrong: the relative rotation is poorly determined by them, and the cameras
// the pass keeps are never worse than the a-priori ones beyond 0.1 px.
TEST(HoldOutCheck, BunchedTiesNeverMakeItWorse) {
  for (unsigned seed = 1; seed <= 8; ++seed) {
    Options opt;
    opt.ties = 27;
    opt.noise_px = 0.15;
    opt.corner_px = 250;
    opt.wrong_fraction = 0.1;
    const Outcome o = runPair(opt, seed);
    CHECK(o.final_error_px <= 0.1);
  }
}

// Too few ties for the check: the pair keeps its a-priori models and says why.
TEST(HoldOutCheck, TooFewTiesKeepApriori) {
  Options opt;
  opt.ties = minTies(HoldOutParams{}) - 1;
  opt.apriori_turn_px = 2.0;
  const Outcome o = runPair(opt, 3);
  CHECK_FALSE(o.check.pairs.at(0).adjusted);
  CHECK(o.check.pairs.at(0).reason.find("fewer than") != std::string::npos);
  DOUBLES_EQUAL(o.apriori_error_px, o.final_error_px, 1e-9);
}
