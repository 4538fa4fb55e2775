#include "ground/sim/TraversePlan.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "ground/cli/Cli.hpp"
#include "ground/sim/Noise.hpp"

namespace areomap::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr uint64_t kPathStream = 0x7a11;      // leg lengths and turns
constexpr uint64_t kOdometryStream = 0x0d0e;  // odometry errors

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
  plan.truth.push_back(SitePose{});
  plan.apriori.push_back(SitePose{});
  for (int k = 1; k < s.sites; ++k) {
    const uint64_t h = hash3(seed, kPathStream, k);
    const double distance = s.leg_min_m + unit(mix64(h + 1)) * (s.leg_max_m - s.leg_min_m);
    const double turn = (2.0 * unit(mix64(h + 2)) - 1.0) * s.max_turn_deg * kDeg;
    const SitePose& before = plan.truth.back();
    SitePose after;
    after.heading_rad = before.heading_rad + turn;
    after.position_m.x() = before.position_m.x() + distance * std::cos(after.heading_rad);
    after.position_m.y() = before.position_m.y() + distance * std::sin(after.heading_rad);
    after.position_m.z() = e0 - height(after.position_m.x(), after.position_m.y());

    OdometryLeg leg;
    leg.from = plan.ids.back();
    leg.distance_m = distance;
    leg.sigma_m = Eigen::Vector3d(s.drift_fraction * distance, s.drift_fraction * distance,
                                  s.vertical_drift_fraction * distance);
    leg.sigma_heading_rad = s.heading_drift_deg * kDeg;
    const Eigen::Vector3d true_delta = before.toSite(after.position_m);
    for (int a = 0; a < 3; ++a) leg.delta_m[a] = true_delta[a] + leg.sigma_m[a] * odometryNoise(seed, k, a);
    leg.delta_heading_rad = turn + leg.sigma_heading_rad * odometryNoise(seed, k, 3);

    plan.ids.push_back(traverseSiteId(k));
    plan.truth.push_back(after);
    plan.apriori.push_back(composePose(plan.apriori.back(), leg.delta_m, leg.delta_heading_rad));
    plan.legs.push_back(leg);
  }
  return plan;
}

}  // namespace areomap::sim
