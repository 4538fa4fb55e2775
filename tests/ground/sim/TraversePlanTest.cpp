#include <cmath>
#include <string>
#include <vector>

#include "ground/cli/Cli.hpp"
#include "ground/sim/TraversePlan.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using namespace areomap::sim;

namespace {

constexpr double kPlanRadPerDeg = M_PI / 180.0;
constexpr int kSeeds = 500;

// A pose's site point in the traverse frame, written out (not through SitePose): heading clockwise from
// north turns +X towards +Y.
Eigen::Vector3d toTraverse(const SitePose& pose, const Eigen::Vector3d& p) {
  const double c = std::cos(pose.heading_rad), s = std::sin(pose.heading_rad);
  return pose.position_m + Eigen::Vector3d(c * p.x() - s * p.y(), s * p.x() + c * p.y(), p.z());
}

// The traverse point in the pose's site frame.
Eigen::Vector3d toSite(const SitePose& pose, const Eigen::Vector3d& q) {
  const Eigen::Vector3d d = q - pose.position_m;
  const double c = std::cos(pose.heading_rad), s = std::sin(pose.heading_rad);
  return Eigen::Vector3d(c * d.x() + s * d.y(), -s * d.x() + c * d.y(), d.z());
}

double wrapAngle(double a) {
  return std::atan2(std::sin(a), std::cos(a));
}

struct Moments {
  double n = 0.0, sum = 0.0, sum2 = 0.0;
  void add(double v) {
    n += 1.0;
    sum += v;
    sum2 += v * v;
  }
  double mean() const { return sum / n; }
  double variance() const { return sum2 / n - mean() * mean(); }
};

// A smooth ground: a regional slope and a swell.
double ground(double x, double y) {
  return 0.01 * x - 0.02 * y + 0.3 * std::sin(y / 7.0) * std::cos(x / 11.0);
}

}  // namespace

TEST_GROUP(TraversePlan){};

TEST(TraversePlan, SitesAre10To30MApartAlongAWindingPath) {
  const TraverseSettings settings;  // defaults: 5 sites, 10-30 m, turns up to 40 degrees
  double shortest = 1e9, longest = 0.0, largest_turn = 0.0;
  int turns_above_20 = 0, legs = 0;
  for (int seed = 0; seed < kSeeds; ++seed) {
    const TraversePlan plan = planTraverse(settings, static_cast<uint64_t>(seed));
    CHECK_EQUAL(5, static_cast<int>(plan.truth.size()));
    CHECK_EQUAL(4, static_cast<int>(plan.legs.size()));
    CHECK(plan.truth[0].isIdentity());
    CHECK(plan.apriori[0].isIdentity());
    STRCMP_EQUAL("site01", plan.ids[0].c_str());
    STRCMP_EQUAL("site05", plan.ids[4].c_str());
    for (std::size_t k = 1; k < plan.truth.size(); ++k) {
      const double d = (plan.truth[k].position_m - plan.truth[k - 1].position_m).head<2>().norm();
      shortest = std::min(shortest, d);
      longest = std::max(longest, d);
      DOUBLES_EQUAL(d, plan.legs[k - 1].distance_m, 1e-9);
      DOUBLES_EQUAL(0.0, plan.truth[k].position_m.z(), 0.0);  // flat ground
      const double turn = std::fabs(wrapAngle(plan.truth[k].heading_rad - plan.truth[k - 1].heading_rad));
      largest_turn = std::max(largest_turn, turn);
      if (turn > 20.0 * kPlanRadPerDeg) ++turns_above_20;
      ++legs;
      STRCMP_EQUAL(plan.ids[k - 1].c_str(), plan.legs[k - 1].from.c_str());
    }
  }
  printf("\n%d legs: %.2f to %.2f m, largest turn %.1f deg, %.0f %% of turns above 20 deg\n", legs, shortest,
         longest, largest_turn / kPlanRadPerDeg, 100.0 * turns_above_20 / legs);
  CHECK(shortest >= 10.0 && shortest < 10.5);
  CHECK(longest <= 30.0 && longest > 29.5);
  CHECK(largest_turn <= 40.0 * kPlanRadPerDeg + 1e-12);
  DOUBLES_EQUAL(0.5, static_cast<double>(turns_above_20) / legs, 0.06);  // uniform in +-40 degrees
}

TEST(TraversePlan, OdometryErrorsAreUnitNormalInTheirSigmas) {
  // Over 2000 legs, each component's error divided by its sigma: mean 0, variance 1 (4-sigma bands of the
  // estimates: 4 / sqrt(n) for the mean, 4 sqrt(2 / n) for the variance), no error beyond 5 sigma.
  TraverseSettings settings;
  settings.drift_fraction = 0.05;
  settings.vertical_drift_fraction = 0.01;
  settings.heading_drift_deg = 2.0;
  Moments m[4];
  double worst = 0.0;
  for (int seed = 0; seed < kSeeds; ++seed) {
    const TraversePlan plan = planTraverse(settings, static_cast<uint64_t>(seed), ground);
    for (std::size_t k = 1; k < plan.truth.size(); ++k) {
      const OdometryLeg& leg = plan.legs[k - 1];
      const double d = leg.distance_m;
      DOUBLES_EQUAL(0.05 * d, leg.sigma_m.x(), 1e-12);
      DOUBLES_EQUAL(0.05 * d, leg.sigma_m.y(), 1e-12);
      DOUBLES_EQUAL(0.01 * d, leg.sigma_m.z(), 1e-12);
      DOUBLES_EQUAL(2.0 * kPlanRadPerDeg, leg.sigma_heading_rad, 1e-15);
      const Eigen::Vector3d truth = toSite(plan.truth[k - 1], plan.truth[k].position_m);
      const double e[4] = {
          (leg.delta_m.x() - truth.x()) / leg.sigma_m.x(), (leg.delta_m.y() - truth.y()) / leg.sigma_m.y(),
          (leg.delta_m.z() - truth.z()) / leg.sigma_m.z(),
          wrapAngle(leg.delta_heading_rad - (plan.truth[k].heading_rad - plan.truth[k - 1].heading_rad)) /
              leg.sigma_heading_rad};
      for (int a = 0; a < 4; ++a) {
        m[a].add(e[a]);
        worst = std::max(worst, std::fabs(e[a]));
      }
    }
  }
  const double n = m[0].n;
  printf(
      "\nnormalised odometry errors over %.0f legs (x, y, z, heading): mean %.3f %.3f %.3f %.3f, variance "
      "%.3f %.3f %.3f %.3f, largest %.2f\n",
      n, m[0].mean(), m[1].mean(), m[2].mean(), m[3].mean(), m[0].variance(), m[1].variance(),
      m[2].variance(), m[3].variance(), worst);
  for (const Moments& a : m) {
    CHECK(std::fabs(a.mean()) < 4.0 / std::sqrt(n));
    CHECK(std::fabs(a.variance() - 1.0) < 4.0 * std::sqrt(2.0 / n));
  }
  CHECK(worst < 5.0);
}

TEST(TraversePlan, AprioriPosesChainTheOdometryAsARandomWalk) {
  const TraverseSettings settings;
  Moments heading_error[5], position_error2[5];
  for (int seed = 0; seed < kSeeds; ++seed) {
    const TraversePlan plan = planTraverse(settings, static_cast<uint64_t>(seed), ground);
    SitePose chained;  // dead reckoning, written out here
    for (std::size_t k = 1; k < plan.truth.size(); ++k) {
      const OdometryLeg& leg = plan.legs[k - 1];
      chained.position_m = toTraverse(chained, leg.delta_m);
      chained.heading_rad += leg.delta_heading_rad;
      CHECK((chained.position_m - plan.apriori[k].position_m).norm() < 1e-9);
      DOUBLES_EQUAL(chained.heading_rad, plan.apriori[k].heading_rad, 1e-12);
      heading_error[k].add(wrapAngle(plan.apriori[k].heading_rad - plan.truth[k].heading_rad));
      position_error2[k].add((plan.apriori[k].position_m - plan.truth[k].position_m).head<2>().squaredNorm());
    }
  }
  // The heading error after k legs has variance k sigma^2 (a random walk); the position error grows.
  const double sigma = settings.heading_drift_deg * kPlanRadPerDeg;
  printf("\nheading error sd after 1..4 legs (deg):");
  for (int k = 1; k < 5; ++k) printf(" %.2f", std::sqrt(heading_error[k].variance()) / kPlanRadPerDeg);
  printf("; horizontal position error RMS (m):");
  for (int k = 1; k < 5; ++k) printf(" %.2f", std::sqrt(position_error2[k].mean()));
  printf("\n");
  for (int k = 1; k < 5; ++k) {
    DOUBLES_EQUAL(1.0, heading_error[k].variance() / (k * sigma * sigma), 4.0 * std::sqrt(2.0 / kSeeds));
    if (k > 1) CHECK(position_error2[k].mean() > position_error2[k - 1].mean());
  }
  // One leg: the error is the odometry's own, RMS sqrt(2) * 5 % of a mean 20 m leg (~1.4 m).
  DOUBLES_EQUAL(std::sqrt(2.0) * 0.05 * std::sqrt((10.0 * 10.0 + 10.0 * 30.0 + 30.0 * 30.0) / 3.0),
                std::sqrt(position_error2[1].mean()), 0.15);
}

TEST(TraversePlan, SiteOriginsFollowTheGround) {
  const TraversePlan plan = planTraverse(TraverseSettings{}, 7, ground);
  const double e0 = ground(0.0, 0.0);
  for (const SitePose& pose : plan.truth) {
    // Every origin as high above the ground under it as the first one (Z down).
    DOUBLES_EQUAL(e0 - ground(pose.position_m.x(), pose.position_m.y()), pose.position_m.z(), 1e-12);
  }
  // The horizontal path does not depend on the ground.
  const TraversePlan flat = planTraverse(TraverseSettings{}, 7);
  for (std::size_t k = 0; k < plan.truth.size(); ++k) {
    CHECK(flat.truth[k].position_m.head<2>() == plan.truth[k].position_m.head<2>());
    DOUBLES_EQUAL(flat.truth[k].heading_rad, plan.truth[k].heading_rad, 0.0);
  }
}

TEST(TraversePlan, SameSeedSamePlanOtherSeedOtherPlan) {
  TraverseSettings settings;
  settings.sites = 8;
  const TraversePlan a = planTraverse(settings, 42, ground), b = planTraverse(settings, 42, ground);
  const TraversePlan c = planTraverse(settings, 43, ground);
  CHECK_EQUAL(8, static_cast<int>(a.truth.size()));
  bool differs = false;
  for (std::size_t k = 0; k < a.truth.size(); ++k) {
    CHECK(a.truth[k].position_m == b.truth[k].position_m);
    CHECK(a.apriori[k].position_m == b.apriori[k].position_m);
    DOUBLES_EQUAL(a.apriori[k].heading_rad, b.apriori[k].heading_rad, 0.0);
    differs = differs || a.truth[k].position_m != c.truth[k].position_m;
  }
  CHECK(differs);
}

TEST(TraversePlan, ImpossibleTraversesAreRejected) {
  auto error = [](TraverseSettings s) -> std::string {
    try {
      validateTraverse(s);
    } catch (const cli::UsageError& e) {
      return e.what();
    }
    return "";
  };
  TraverseSettings s;
  CHECK(error(s).empty());
  s.sites = 0;
  CHECK(error(s).find("--sites") != std::string::npos);
  s.sites = kMaxTraverseSites + 1;
  CHECK(error(s).find("--sites") != std::string::npos);
  s = TraverseSettings{};
  s.leg_min_m = 20.0;
  s.leg_max_m = 10.0;
  CHECK(error(s).find("--leg-min-m") != std::string::npos);
  s = TraverseSettings{};
  s.drift_fraction = 0.0;
  CHECK(error(s).find("--odometry-drift-pct") != std::string::npos);
  s = TraverseSettings{};
  s.heading_drift_deg = -1.0;
  CHECK(error(s).find("--heading-drift-deg") != std::string::npos);
  s = TraverseSettings{};
  s.max_slope_deg = 40.0;
  CHECK(error(s).find("--max-slope-deg") != std::string::npos);
  s = TraverseSettings{};
  s.tilt_sigma_deg = -0.1;
  CHECK(error(s).find("--tilt-sigma-deg") != std::string::npos);
}

TEST(TraversePlan, TraversingStopsCutEachLegOnItsLineAndLeaveThePanoramaSitesWhereTheyWere) {
  TraverseSettings plain;
  plain.sites = 6;
  TraverseSettings stopping = plain;
  stopping.stop_spacing_m = 9.0;
  for (uint64_t seed = 1; seed <= 200; ++seed) {
    const TraversePlan a = planTraverse(plain, seed, ground), b = planTraverse(stopping, seed, ground);
    CHECK_EQUAL(b.ids.size(), b.kinds.size());
    CHECK_EQUAL(b.ids.size(), b.truth.size());
    CHECK_EQUAL(b.ids.size(), b.legs.size() + 1);
    DOUBLES_EQUAL(a.distanceM(), b.distanceM(), 1e-9);
    std::size_t site = 0;  // the panorama site in `a` the stops of `b` lead to
    int stop = 0;
    for (std::size_t k = 0; k < b.ids.size(); ++k) {
      if (k > 0) {
        const OdometryLeg& leg = b.legs[k - 1];
        STRCMP_EQUAL(b.ids[k - 1].c_str(), leg.from.c_str());
        CHECK(leg.distance_m <= stopping.stop_spacing_m + 1e-9);
        DOUBLES_EQUAL(stopping.drift_fraction * leg.distance_m, leg.sigma_m.x(), 1e-12);
        // A leg's odometry is its own: the a-priori pose is the one before moved by it.
        CHECK((toTraverse(b.apriori[k - 1], leg.delta_m) - b.apriori[k].position_m).norm() < 1e-9);
      }
      if (b.kinds[k] == SiteKind::kPanorama) {
        // Every panorama site is where the plan without stops puts it, and has its id.
        STRCMP_EQUAL(a.ids[site].c_str(), b.ids[k].c_str());
        CHECK((a.truth[site].position_m - b.truth[k].position_m).norm() < 1e-9);
        DOUBLES_EQUAL(a.truth[site].heading_rad, b.truth[k].heading_rad, 1e-12);
        ++site;
        stop = 0;
        continue;
      }
      // A stop: on the straight line from the site before to the next one, facing along it, legs equal.
      ++stop;
      STRCMP_EQUAL(traverseStopId(static_cast<int>(site) - 1, stop).c_str(), b.ids[k].c_str());
      const Eigen::Vector3d from = a.truth[site - 1].position_m, to = a.truth[site].position_m;
      const Eigen::Vector2d dir = (to - from).head<2>().normalized();
      const Eigen::Vector2d off = (b.truth[k].position_m - from).head<2>();
      DOUBLES_EQUAL(0.0, dir.x() * off.y() - dir.y() * off.x(), 1e-9);
      CHECK(off.dot(dir) > 0.0 && off.dot(dir) < (to - from).head<2>().norm());
      DOUBLES_EQUAL(a.truth[site].heading_rad, b.truth[k].heading_rad, 1e-12);
      DOUBLES_EQUAL(b.legs[k - 1].distance_m, b.legs[k].distance_m, 1e-9);
      DOUBLES_EQUAL(ground(0, 0) - ground(b.truth[k].position_m.x(), b.truth[k].position_m.y()),
                    b.truth[k].position_m.z(), 1e-12);
    }
    CHECK_EQUAL(a.ids.size(), site);
  }
  // Without stops the plan is what it was before stops existed.
  TraverseSettings none = plain;
  none.stop_spacing_m = 0.0;
  const TraversePlan c = planTraverse(none, 7, ground), d = planTraverse(plain, 7, ground);
  for (std::size_t k = 0; k < c.truth.size(); ++k) CHECK(c.apriori[k].position_m == d.apriori[k].position_m);
}

TEST(TraversePlan, StopSpacingOutsideItsRangeIsRejected) {
  TraverseSettings s;
  s.stop_spacing_m = 0.5;
  try {
    validateTraverse(s);
    FAIL("0.5 m accepted");
  } catch (const cli::UsageError& e) {
    CHECK(std::string(e.what()).find("--stop-spacing-m") != std::string::npos);
  }
  s.sites = kMaxTraverseSites;
  s.stop_spacing_m = 5.0;  // 98 legs of up to 6 parts
  CHECK_THROWS(cli::UsageError, validateTraverse(s));
}

TEST(TraversePlan, ALevelWorldHasNoAttitudeWhateverTheTiltSigma) {
  // --max-slope-deg 0 (the default): no stances, and the plan bit for bit the one of the default settings,
  // with the IMU's sigma at its default or 0.
  TraverseSettings level;
  level.sites = 6;
  level.stop_spacing_m = 12.0;
  const TraversePlan reference = planTraverse(level, 11, ground);
  for (double sigma : {0.0, 0.2, 3.0}) {
    TraverseSettings s = level;
    s.tilt_sigma_deg = sigma;
    const TraversePlan plan = planTraverse(s, 11, ground);
    CHECK(plan.stances.empty());
    CHECK_EQUAL(reference.truth.size(), plan.truth.size());
    for (std::size_t k = 0; k < plan.truth.size(); ++k) {
      CHECK(plan.truth[k].position_m == reference.truth[k].position_m);
      CHECK(plan.apriori[k].position_m == reference.apriori[k].position_m);
      CHECK(plan.truth[k].heading_rad == reference.truth[k].heading_rad);
      CHECK(plan.apriori[k].heading_rad == reference.apriori[k].heading_rad);
    }
  }
  // Sloped ground changes no pose (the path and the site origins), it adds the stances.
  TraverseSettings sloped = level;
  sloped.max_slope_deg = 10.0;
  const TraversePlan plan = planTraverse(sloped, 11, ground);
  CHECK_EQUAL(plan.truth.size(), plan.stances.size());
  for (std::size_t k = 0; k < plan.truth.size(); ++k) {
    CHECK(plan.truth[k].position_m == reference.truth[k].position_m);
    CHECK(plan.apriori[k].position_m == reference.apriori[k].position_m);
  }
}

TEST(TraversePlan, ARoverOnAPlaneTakesThePlanesTilt) {
  // On a plane e = a x + b y + c the rover's down axis is the plane's downward normal and its base is on
  // the plane, whatever its heading: written out, not through standOnGround's algebra.
  const double a = 0.21, b = -0.34, c = 1.7;
  auto plane = [&](double x, double y) { return a * x + b * y + c; };
  const Eigen::Vector3d down_normal = Eigen::Vector3d(a, b, 1.0).normalized();  // Z down, e up = -Z
  for (double heading_deg : {0.0, 37.0, 135.0, -100.0}) {
    SitePose pose;
    pose.position_m = Eigen::Vector3d(4.0, -3.0, 0.5);
    pose.heading_rad = heading_deg * kPlanRadPerDeg;
    const RoverStance stance = standOnGround(pose, plane);
    const Eigen::Vector3d down = pose.rotation() * stance.truth.rotation() * Eigen::Vector3d::UnitZ();
    CHECK((down - down_normal).norm() < 1e-12);
    DOUBLES_EQUAL(plane(4.0, -3.0), stance.base_elevation_m, 1e-12);
    // The rover's forward axis stays in the vertical plane of its heading (no yaw).
    const Eigen::Vector3d forward = pose.rotation() * stance.truth.rotation() * Eigen::Vector3d::UnitX();
    DOUBLES_EQUAL(
        0.0, forward.dot(Eigen::Vector3d(-std::sin(pose.heading_rad), std::cos(pose.heading_rad), 0)), 1e-12);
  }
  // Level ground: no tilt.
  const RoverStance level = standOnGround(SitePose{}, [](double, double) { return 2.0; });
  DOUBLES_EQUAL(0.0, level.truth.roll_rad, 0.0);
  DOUBLES_EQUAL(0.0, level.truth.pitch_rad, 0.0);
}

TEST(TraversePlan, TheImuTiltErrorIsUnitNormalInItsSigma) {
  // Over kSeeds traverses of 5 sites: a-priori minus true roll and pitch, each of the 2 x 2500 errors an
  // independent N(0, T^2). The sample sd of n normals has a relative standard error 1 / sqrt(2 n) (1 %
  // here): within 5 % of T; the mean within 5 T / sqrt(n); roll and pitch uncorrelated (|r| < 5 / sqrt(n)).
  TraverseSettings s;
  s.max_slope_deg = 12.0;
  s.tilt_sigma_deg = 0.3;
  Moments roll, pitch;
  double cross = 0.0;
  for (int seed = 0; seed < kSeeds; ++seed) {
    const TraversePlan plan = planTraverse(s, static_cast<uint64_t>(seed), ground);
    for (const RoverStance& stance : plan.stances) {
      const double dr = (stance.apriori.roll_rad - stance.truth.roll_rad) / kPlanRadPerDeg;
      const double dp = (stance.apriori.pitch_rad - stance.truth.pitch_rad) / kPlanRadPerDeg;
      roll.add(dr);
      pitch.add(dp);
      cross += dr * dp;
    }
  }
  const double n = roll.n;
  CHECK_EQUAL(5 * kSeeds, static_cast<int>(n));
  printf(
      "\nIMU tilt error over %.0f sites, sigma %.2f deg: roll sd %.4f mean %.4f, pitch sd %.4f mean %.4f\n",
      n, s.tilt_sigma_deg, std::sqrt(roll.variance()), roll.mean(), std::sqrt(pitch.variance()),
      pitch.mean());
  for (const Moments* m : {&roll, &pitch}) {
    DOUBLES_EQUAL(s.tilt_sigma_deg, std::sqrt(m->variance()), 0.05 * s.tilt_sigma_deg);
    DOUBLES_EQUAL(0.0, m->mean(), 5.0 * s.tilt_sigma_deg / std::sqrt(n));
  }
  CHECK(std::fabs(cross / n) / (s.tilt_sigma_deg * s.tilt_sigma_deg) < 5.0 / std::sqrt(n));
  // Sigma 0: the IMU is exact.
  s.tilt_sigma_deg = 0.0;
  for (const RoverStance& stance : planTraverse(s, 3, ground).stances) {
    CHECK(stance.apriori.roll_rad == stance.truth.roll_rad &&
          stance.apriori.pitch_rad == stance.truth.pitch_rad);
  }
}
