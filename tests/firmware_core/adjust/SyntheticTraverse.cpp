#include "tests/firmware_core/adjust/SyntheticTraverse.hpp"

#include <cmath>
#include <random>

#include "tests/firmware_core/adjust/SyntheticPanorama.hpp"  // lookRotation, centredPinhole

namespace areomap::test {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr double kImageMarginPx = 10.0;

double groundZ(const std::vector<TraverseFromSite>& truth, int32_t a, int32_t b, double t) {
  return (1.0 - t) * truth[a].position_m.z() + t * truth[b].position_m.z();
}

Vec3 rotationLogOf(const Mat3& r) {
  const Eigen::AngleAxisd aa(r);
  return aa.axis() * aa.angle();
}

}  // namespace

TraversePlan makeTraversePlan(const TraverseConfig& cfg) {
  TraversePlan plan;
  std::mt19937 rng(cfg.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * uni(rng); };

  // Truth: site 0 defines the traverse frame.
  double heading = uniform(-kPi, kPi);
  plan.truth.resize(cfg.sites);
  plan.legs.resize(cfg.sites);
  plan.apriori.resize(cfg.sites);
  for (int32_t k = 1; k < cfg.sites; ++k) {
    const double step = uniform(cfg.min_step_m, cfg.max_step_m);
    heading += uniform(-cfg.max_turn_deg, cfg.max_turn_deg) * kDeg;
    TraverseFromSite& p = plan.truth[k];
    p.position_m = plan.truth[k - 1].position_m +
                   Vec3(step * std::cos(heading), step * std::sin(heading), uniform(-0.05, 0.05) * step);
    const Vec3 tilt(uniform(-1.0, 1.0) * cfg.max_tilt_deg * kDeg,
                    uniform(-1.0, 1.0) * cfg.max_tilt_deg * kDeg, 0.0);
    p.rotation = rotationFromVector(Vec3(0.0, 0.0, uniform(-kPi, kPi))) * rotationFromVector(tilt);
  }
  // Odometry legs and the a-priori chain.
  plan.apriori[0] = plan.truth[0];
  for (int32_t k = 1; k < cfg.sites; ++k) {
    LegMeasurement leg;
    relativePose(plan.truth[k - 1], plan.truth[k], leg.delta_position_m, leg.delta_rotation);
    const double length = leg.delta_position_m.norm();
    leg.sigma_position_m = Vec3(cfg.odo_horizontal_fraction * length, cfg.odo_horizontal_fraction * length,
                                cfg.odo_vertical_fraction * length);
    leg.sigma_rotation_rad =
        Vec3(cfg.odo_tilt_deg * kDeg, cfg.odo_tilt_deg * kDeg, cfg.odo_heading_deg * kDeg);
    LegMeasurement noisy = leg;
    const Vec3 dp(gauss(rng) * leg.sigma_position_m.x(), gauss(rng) * leg.sigma_position_m.y(),
                  gauss(rng) * leg.sigma_position_m.z());
    const Vec3 dr(gauss(rng) * leg.sigma_rotation_rad.x(), gauss(rng) * leg.sigma_rotation_rad.y(),
                  gauss(rng) * leg.sigma_rotation_rad.z());
    noisy.delta_position_m += dp;
    noisy.delta_rotation = leg.delta_rotation * rotationFromVector(dr);
    plan.legs[k] = cfg.odometry_noise ? noisy : leg;
    TraverseFromSite& a = plan.apriori[k];
    a.position_m = plan.apriori[k - 1].position_m + plan.apriori[k - 1].rotation * noisy.delta_position_m;
    a.rotation = plan.apriori[k - 1].rotation * noisy.delta_rotation;
  }
  // Cameras: a ring of stereo pairs about the mast, EO in the site frame.
  const InteriorOrientation io = centredPinhole(cfg.f_px, cfg.width, cfg.height);
  for (int32_t k = 0; k < cfg.sites; ++k) {
    const double offset = uniform(0.0, 2.0 * kPi / cfg.azimuths);
    for (int32_t a = 0; a < cfg.azimuths; ++a) {
      const double az = offset + a * 2.0 * kPi / cfg.azimuths;
      const Mat3 m = lookRotation(az, cfg.elevation_deg * kDeg);
      const Vec3 right = m.row(0).transpose();
      for (int32_t side = 0; side < 2; ++side) {
        SiteCamera c;
        c.site = k;
        c.io = io;
        c.m_site = m;
        c.centre_in_site_m =
            Vec3(0.0, 0.0, -cfg.mast_height_m) + right * ((side == 0 ? -0.5 : 0.5) * cfg.baseline_m);
        plan.cameras.push_back(c);
      }
    }
  }
  // Points between neighbouring sites, observed by every camera of every site that sees them.
  for (int32_t k = 1; k < cfg.sites; ++k) {
    const Vec3 a = plan.truth[k - 1].position_m;
    const Vec3 b = plan.truth[k].position_m;
    const Vec3 along = (b - a).normalized();
    const Vec3 lateral = Vec3(-along.y(), along.x(), 0.0).normalized();
    for (int32_t i = 0; i < cfg.points_per_leg; ++i) {
      const double t = uniform(0.15, 0.85);
      Vec3 x = a + t * (b - a) + lateral * uniform(-6.0, 6.0);
      x.z() = groundZ(plan.truth, k - 1, k, t) + uniform(-0.3, 0.3);
      std::vector<TraverseObservation> seen;
      int32_t first_site = -1;
      bool cross = false;
      for (int32_t c = 0; c < static_cast<int32_t>(plan.cameras.size()); ++c) {
        const SiteCamera& cam = plan.cameras[c];
        if (cam.site == cfg.isolated_site) continue;
        if ((x - plan.truth[cam.site].position_m).norm() > cfg.max_range_m) continue;
        Vec3 centre;
        Mat3 m;
        cameraInTraverse(plan.truth[cam.site], cam, centre, m);
        Vec2 px;
        if (!ok(collinearity(cam.io, centre, m, x, px))) continue;
        if (px.x() < kImageMarginPx || px.y() < kImageMarginPx || px.x() > cfg.width - kImageMarginPx ||
            px.y() > cfg.height - kImageMarginPx)
          continue;
        if (static_cast<int32_t>(seen.size()) >= kMaxObsPerCrossSitePoint) break;
        TraverseObservation o;
        o.site = cam.site;
        o.camera = c;
        o.sigma_px = cfg.noise_px > 0.0 ? cfg.noise_px : 0.3;
        o.ideal_px = px + Vec2(gauss(rng), gauss(rng)) * cfg.noise_px;
        if (uni(rng) < cfg.outlier_fraction) {
          const double angle = uniform(0.0, 2.0 * kPi);
          o.ideal_px += uniform(10.0, 50.0) * Vec2(std::cos(angle), std::sin(angle));
          o.outlier = true;
        }
        if (first_site < 0) first_site = cam.site;
        cross = cross || cam.site != first_site;
        seen.push_back(o);
      }
      if (!cross) continue;
      const int32_t index = static_cast<int32_t>(plan.points.size());
      plan.points.push_back(x);
      for (TraverseObservation& o : seen) {
        o.point = index;
        plan.observations.push_back(o);
      }
    }
  }
  return plan;
}

template <typename Adjuster>
bool loadTraverse(const TraversePlan& plan, int32_t first, int32_t last, bool apriori_start,
                  Adjuster& adjuster, TraverseLoad& load) {
  bool all = true;
  if (first == 0) {
    adjuster.clear();
    load.camera.assign(plan.cameras.size(), -1);
    load.point.assign(plan.points.size(), -1);
    load.observation.assign(plan.observations.size(), -1);
  }
  for (int32_t k = first; k < last; ++k) {
    int32_t site = -1;
    const Status s = k == 0
                         ? adjuster.addFirstSite(plan.truth[0], site)
                         : adjuster.addSite(plan.legs[k], apriori_start ? &plan.apriori[k] : nullptr, site);
    all = all && ok(s) && site == k;
    for (size_t c = 0; c < plan.cameras.size(); ++c) {
      const SiteCamera& cam = plan.cameras[c];
      if (cam.site != k) continue;
      all = all && ok(adjuster.addCamera(k, cam.io, cam.centre_in_site_m, cam.m_site, load.camera[c]));
    }
    for (size_t o = 0; o < plan.observations.size(); ++o) {
      const TraverseObservation& ob = plan.observations[o];
      if (ob.site != k) continue;
      if (load.point[ob.point] < 0) all = all && ok(adjuster.addPoint(nullptr, load.point[ob.point]));
      all = all && ok(adjuster.addObservation(load.point[ob.point], load.camera[ob.camera], ob.ideal_px,
                                              ob.sigma_px));
      load.observation[o] = adjuster.observationCount() - 1;
    }
  }
  return all;
}

template bool loadTraverse(const TraversePlan&, int32_t, int32_t, bool, SitePoseAdjuster&, TraverseLoad&);
template bool loadTraverse(const TraversePlan&, int32_t, int32_t, bool, GroundSitePoseAdjuster&,
                           TraverseLoad&);

Vec6 poseError(const TraverseFromSite& estimate, const TraverseFromSite& truth) {
  Vec6 e;
  e.head<3>() = estimate.position_m - truth.position_m;
  e.tail<3>() = rotationLogOf(estimate.rotation * truth.rotation.transpose());
  return e;
}

}  // namespace areomap::test
