#include "ground/traverse/TruthCheck.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>

#include <nlohmann/json.hpp>

#include "firmware_core/base/Angles.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/io/CameraFile.hpp"

namespace areomap::traverse {

namespace {

double wrapDeg(double rad) {
  return std::remainder(rad, 2.0 * kPi) * kRadToDeg;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))];
}

}  // namespace

namespace {

// How a site's pass maps its truly levelled frame: turned by the attitude error E = R_apriori R_true^T about
// the rover's base b (x' = E (x - b) + b); the identity without an attitude.
struct SiteLevelling {
  Eigen::Matrix3d error = Eigen::Matrix3d::Identity();
  Eigen::Vector3d base_m = Eigen::Vector3d::Zero();
};

SiteLevelling levellingOf(const TraverseSite& site) {
  SiteLevelling l;
  const std::string path = site.dir + "/truth/sim.json";
  std::ifstream in(path);
  if (!in) return l;
  const nlohmann::json j = nlohmann::json::parse(in);
  if (!j.contains("traverse") || !j["traverse"].contains("true_attitude")) return l;
  const nlohmann::json& t = j["traverse"];
  const auto attitude = [](const nlohmann::json& a) {
    RoverAttitude r;
    r.roll_rad = a.at("roll_deg").get<double>() * kDegToRad;
    r.pitch_rad = a.at("pitch_deg").get<double>() * kDegToRad;
    return r.rotation();
  };
  l.error = attitude(t.at("apriori_attitude")) * attitude(t.at("true_attitude")).transpose();
  const double site_z = t.at("true_pose").at("position_m").at(2).get<double>();
  l.base_m = Eigen::Vector3d(0.0, 0.0, -t.at("base_elevation_m").get<double>() - site_z);
  return l;
}

}  // namespace

RelativePose mappedTruePose(const TraverseSite& site_a, const TraverseSite& site_b, const SitePose& true_a,
                            const SitePose& true_b) {
  const RelativePose level = relativePose(true_a, true_b);
  const SiteLevelling la = levellingOf(site_a), lb = levellingOf(site_b);
  // x_a' = E_a (x_a - b_a) + b_a, x_a = R x_b + t, x_b = E_b^T (x_b' - b_b) + b_b.
  const Eigen::Matrix3d r = level.rotation();
  const Eigen::Matrix3d rotation = la.error * r * lb.error.transpose();
  const Eigen::Vector3d translation =
      la.error * (r * (lb.base_m - lb.error.transpose() * lb.base_m) + level.translation_m - la.base_m) +
      la.base_m;
  if (la.error.isIdentity(0.0) && lb.error.isIdentity(0.0)) return level;
  return relativePoseOf(rotation, translation);
}

TruthCheck checkAgainstTruth(const CrossTieResult& result, const TraverseSite& site_a,
                             const TraverseSite& site_b, const SitePose& true_a, const SitePose& true_b,
                             double gross_px) {
  TruthCheck c;
  c.gross_px = gross_px;
  const RelativePose truth = mappedTruePose(site_a, site_b, true_a, true_b);
  c.true_tilt_deg = truth.tilt_rad.norm() * kRadToDeg;
  c.registration_tilt_deg = (result.registration.a_from_b.tilt_rad - truth.tilt_rad).norm() * kRadToDeg;
  c.ties_tilt_deg = (result.a_from_b.tilt_rad - truth.tilt_rad).norm() * kRadToDeg;
  c.registration_xy_m = (result.registration.a_from_b.translation_m - truth.translation_m).head<2>().norm();
  c.registration_z_m = result.registration.a_from_b.translation_m.z() - truth.translation_m.z();
  c.registration_heading_deg = wrapDeg(result.registration.a_from_b.heading_rad - truth.heading_rad);
  c.ties_xy_m = (result.a_from_b.translation_m - truth.translation_m).head<2>().norm();
  c.ties_z_m = result.a_from_b.translation_m.z() - truth.translation_m.z();
  c.ties_heading_deg = wrapDeg(result.a_from_b.heading_rad - truth.heading_rad);
  if (result.ties.empty()) return c;

  const DemGrid dem_b = readDemGeoTiff(site_b.dir + "/" + kTruthDemFile);
  std::map<std::string, CameraModel> models;  // "site/stem"
  auto model = [&](const std::string& site, const std::string& stem) -> const CameraModel& {
    const std::string key = site + "/" + stem;
    auto it = models.find(key);
    if (it == models.end()) {
      const std::string dir = site == site_a.id ? site_a.dir : site_b.dir;
      it = models
               .emplace(key, io::readCameraModelFile(dir + "/" + kTruthModelsFolder + "/" + stem + ".cahvor"))
               .first;
    }
    return it->second;
  };
  for (const CrossTie& t : result.ties) {
    const CrossTieObservation* source = nullptr;
    for (const CrossTieObservation& o : t.observations) {
      if (o.source) source = &o;
    }
    if (source == nullptr) continue;
    Vec3 origin, dir;
    double range = 0.0;
    const bool found = ok(unproject(model(source->site, source->image), source->pixel_px, origin, dir)) &&
                       castRayOnDem(dem_b, origin, dir, 100.0, range);
    const Eigen::Vector3d pb = origin + range * dir;
    const Eigen::Vector3d pa = truth.toA(pb);
    for (const CrossTieObservation& o : t.observations) {
      if (o.source) continue;
      Vec2 px;
      if (!found || !ok(project(model(o.site, o.image), o.site == site_a.id ? pa : pb, px))) {
        ++c.no_truth;
        continue;
      }
      c.errors_px.push_back((px - o.pixel_px).norm());
      if (o.site == site_a.id) c.cross_errors_px.push_back(c.errors_px.back());
    }
  }
  c.cross_median_px = quantile(c.cross_errors_px, 0.5);
  c.cross_p90_px = quantile(c.cross_errors_px, 0.9);
  c.cross_gross = static_cast<int>(std::count_if(c.cross_errors_px.begin(), c.cross_errors_px.end(),
                                                 [&](double e) { return e > gross_px; }));
  c.median_px = quantile(c.errors_px, 0.5);
  c.p90_px = quantile(c.errors_px, 0.9);
  c.gross = static_cast<int>(
      std::count_if(c.errors_px.begin(), c.errors_px.end(), [&](double e) { return e > gross_px; }));
  return c;
}

}  // namespace areomap::traverse
