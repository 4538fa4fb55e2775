#include "ground/sim/TraversePlan.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "ground/cli/Cli.hpp"
#include "ground/sim/Noise.hpp"
#include "ground/sim/SimConfig.hpp"

namespace areomap::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr uint64_t kPathStream = 0x7a11;      // leg lengths and turns
constexpr uint64_t kOdometryStream = 0x0d0e;  // odometry errors
constexpr uint64_t kAttitudeStream = 0xa771;  // the IMU's tilt errors

std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// The n-th standard normal of leg `leg`'s odometry errors.
double odometryNoise(uint64_t seed, int leg, int n) {
  const uint64_t h = hash3(seed, kOdometryStream, leg, static_cast<uint64_t>(n));
  return gaussian(mix64(h), mix64(h + 1));
}

// The equal parts a leg of `distance_m` is cut into: none longer than the stop spacing (0: one part).
int legParts(double distance_m, double stop_spacing_m) {
  if (stop_spacing_m <= 0.0) return 1;
  return std::max(1, static_cast<int>(std::ceil(distance_m / stop_spacing_m - 1e-9)));
}

}  // namespace

double TraversePlan::distanceM() const {
  double sum = 0.0;
  for (const OdometryLeg& leg : legs) sum += leg.distance_m;
  return sum;
}

std::string traverseSiteId(int index) {
  char buffer[16];
  std::snprintf(buffer, sizeof(buffer), "site%02d", index + 1);
  return buffer;
}

std::string traverseStopId(int index, int stop) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "stop%02d-%d", index + 1, stop);
  return buffer;
}

void validateTraverse(const TraverseSettings& s) {
  auto fail = [](const std::string& option, const std::string& what) {
    throw cli::UsageError("impossible traverse: " + option + ": " + what);
  };
  if (s.sites < 1 || s.sites > kMaxTraverseSites)
    fail("--sites", std::to_string(s.sites) + " outside 1.." + std::to_string(kMaxTraverseSites));
  if (!(s.leg_min_m >= 1.0 && s.leg_max_m >= s.leg_min_m && s.leg_max_m <= 200.0))
    fail("--leg-min-m/--leg-max-m",
         "need 1 <= MIN <= MAX <= 200 m, got " + num(s.leg_min_m) + " and " + num(s.leg_max_m));
  if (!(s.max_turn_deg >= 0.0 && s.max_turn_deg <= 180.0)) fail("--max-turn-deg", "outside 0..180");
  if (!(s.drift_fraction > 0.0 && s.drift_fraction <= 0.5)) fail("--odometry-drift-pct", "outside (0, 50]");
  if (!(s.vertical_drift_fraction > 0.0 && s.vertical_drift_fraction <= 0.5))
    fail("--vertical-drift-pct", "outside (0, 50]");
  if (!(s.heading_drift_deg > 0.0 && s.heading_drift_deg <= 45.0))
    fail("--heading-drift-deg", "outside (0, 45]");
  if (!(s.stop_spacing_m == 0.0 || (s.stop_spacing_m >= 1.0 && s.stop_spacing_m <= 200.0)))
    fail("--stop-spacing-m", num(s.stop_spacing_m) + ": 0 (no stops) or 1..200 m");
  if (!(s.max_slope_deg >= 0.0 && s.max_slope_deg <= kMaxSlopeDeg))
    fail("--max-slope-deg", num(s.max_slope_deg) + " outside 0.." + num(kMaxSlopeDeg) + " degrees");
  if (!(s.tilt_sigma_deg >= 0.0 && s.tilt_sigma_deg <= 5.0)) fail("--tilt-sigma-deg", "outside 0..5");
  if (s.stop_spacing_m > 0.0 && s.sites > 1) {
    const int parts = legParts(s.leg_max_m, s.stop_spacing_m);
    if ((s.sites - 1) * parts + 1 > kMaxTraverseSites) {
      fail("--stop-spacing-m", "up to " + std::to_string((s.sites - 1) * parts + 1) +
                                   " sites and stops, more than " + std::to_string(kMaxTraverseSites));
    }
  }
}

RoverStance standOnGround(const SitePose& pose, const std::function<double(double, double)>& ground) {
  // Least squares e = e0 + gx x + gy y over the contacts: they are symmetric about the centre in x and in y,
  // so the normal equations are diagonal.
  double e0 = 0.0, sx = 0.0, sy = 0.0, xx = 0.0, yy = 0.0;
  for (const auto& wheel : kWheelContacts) {
    const Eigen::Vector3d p = pose.toTraverse(Eigen::Vector3d(wheel[0], wheel[1], 0.0));
    const double e = ground ? ground(p.x(), p.y()) : 0.0;
    e0 += e / kWheelCount;
    sx += wheel[0] * e;
    sy += wheel[1] * e;
    xx += wheel[0] * wheel[0];
    yy += wheel[1] * wheel[1];
  }
  const double gx = sx / xx, gy = sy / yy;  // elevation gradient along the rover's x (forward) and y (right)
  // The rover's down axis Ry(pitch) Rx(roll) e_z = (sin p cos r, -sin r, cos p cos r) must be the plane's
  // downward normal (gx, gy, 1) / n (Z down): uphill ahead lifts the nose, uphill to the right lifts the
  // right side (negative roll).
  RoverStance stance;
  stance.truth.pitch_rad = std::atan(gx);
  stance.truth.roll_rad = -std::asin(gy / std::sqrt(1.0 + gx * gx + gy * gy));
  stance.apriori = stance.truth;
  stance.base_elevation_m = e0;
  return stance;
}

SitePose composePose(const SitePose& from, const Eigen::Vector3d& delta_m, double delta_heading_rad) {
  SitePose to;
  to.position_m = from.toTraverse(delta_m);
  to.heading_rad = from.heading_rad + delta_heading_rad;
  return to;
}

TraversePlan planTraverse(const TraverseSettings& s, uint64_t seed,
                          const std::function<double(double, double)>& ground_elevation_up_m) {
  validateTraverse(s);
  auto height = [&](double x, double y) { return ground_elevation_up_m ? ground_elevation_up_m(x, y) : 0.0; };
  const double e0 = height(0.0, 0.0);
  TraversePlan plan;
  plan.ids.push_back(traverseSiteId(0));
  plan.kinds.push_back(SiteKind::kPanorama);
  plan.truth.push_back(SitePose{});
  plan.apriori.push_back(SitePose{});
  for (int k = 1; k < s.sites; ++k) {
    const uint64_t h = hash3(seed, kPathStream, k);
    const double distance = s.leg_min_m + unit(mix64(h + 1)) * (s.leg_max_m - s.leg_min_m);
    const double turn = (2.0 * unit(mix64(h + 2)) - 1.0) * s.max_turn_deg * kDeg;
    const SitePose start = plan.truth.back();
    const double heading = start.heading_rad + turn;
    // The leg in equal parts, none longer than the stop spacing: a stop at the end of each but the last.
    const int parts = legParts(distance, s.stop_spacing_m);
    for (int part = 1; part <= parts; ++part) {
      const SitePose& before = plan.truth.back();
      const double along = distance * part / parts;
      SitePose after;
      after.heading_rad = heading;
      after.position_m.x() = start.position_m.x() + along * std::cos(heading);
      after.position_m.y() = start.position_m.y() + along * std::sin(heading);
      after.position_m.z() = e0 - height(after.position_m.x(), after.position_m.y());

      OdometryLeg leg;
      leg.from = plan.ids.back();
      leg.distance_m = distance / parts;
      leg.sigma_m = Eigen::Vector3d(s.drift_fraction * leg.distance_m, s.drift_fraction * leg.distance_m,
                                    s.vertical_drift_fraction * leg.distance_m);
      leg.sigma_heading_rad = s.heading_drift_deg * kDeg;
      const Eigen::Vector3d true_delta = before.toSite(after.position_m);
      const int noise = 4 * (part - 1);  // part 1 draws what a leg without stops draws
      for (int a = 0; a < 3; ++a)
        leg.delta_m[a] = true_delta[a] + leg.sigma_m[a] * odometryNoise(seed, k, noise + a);
      leg.delta_heading_rad = (after.heading_rad - before.heading_rad) +
                              leg.sigma_heading_rad * odometryNoise(seed, k, noise + 3);

      const bool stop = part < parts;
      plan.ids.push_back(stop ? traverseStopId(k - 1, part) : traverseSiteId(k));
      plan.kinds.push_back(stop ? SiteKind::kStop : SiteKind::kPanorama);
      plan.truth.push_back(after);
      plan.apriori.push_back(composePose(plan.apriori.back(), leg.delta_m, leg.delta_heading_rad));
      plan.legs.push_back(leg);
    }
  }
  if (s.max_slope_deg > 0.0) {
    for (std::size_t k = 0; k < plan.truth.size(); ++k) {
      RoverStance stance = standOnGround(plan.truth[k], ground_elevation_up_m);
      const uint64_t h = hash3(seed, kAttitudeStream, static_cast<int64_t>(k));
      stance.apriori.roll_rad += s.tilt_sigma_deg * kDeg * gaussian(mix64(h), mix64(h + 1));
      stance.apriori.pitch_rad += s.tilt_sigma_deg * kDeg * gaussian(mix64(h + 2), mix64(h + 3));
      plan.stances.push_back(stance);
    }
  }
  return plan;
}

}  // namespace areomap::sim
