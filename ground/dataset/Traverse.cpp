#include "ground/dataset/Traverse.hpp"

#include <cctype>
#include <cmath>
#include <filesystem>
#include <set>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "ground/dataset/JsonFields.hpp"
#include "ground/dataset/TruthFiles.hpp"

namespace areomap {
namespace {

using Json = nlohmann::json;
using OrderedJson = nlohmann::ordered_json;

constexpr double kDeg = M_PI / 180.0;

OrderedJson vec3Json(const Eigen::Vector3d& v) {
  return OrderedJson::array({v.x(), v.y(), v.z()});
}

OrderedJson poseJson(const SitePose& pose) {
  return {{"position_m", vec3Json(pose.position_m)}, {"heading_deg", pose.heading_rad / kDeg}};
}

// The file named by `dir`: DIR/name, or `dir` itself when it already names a file called `name`.
std::string fileIn(const std::string& dir, const std::string& name) {
  std::error_code ec;
  if (std::filesystem::path(dir).filename() == name && std::filesystem::is_regular_file(dir, ec)) return dir;
  return joinPath(dir, name);
}

// A member that must be there.
const Json& member(const JsonFieldReader& r, const Json& object, const std::string& key,
                   const std::string& field) {
  if (!object.contains(key) || object[key].is_null()) r.fail(field, "missing (required)");
  return object[key];
}

// {"position_m": [x, y, z], "heading_deg": h}
SitePose readPose(const JsonFieldReader& r, const Json& j, const std::string& field) {
  if (!j.is_object()) r.fail(field, "expected an object {\"position_m\": [x, y, z], \"heading_deg\": h}");
  SitePose pose;
  pose.position_m = r.vec3(member(r, j, "position_m", field + ".position_m"), field + ".position_m");
  pose.heading_rad =
      r.number(member(r, j, "heading_deg", field + ".heading_deg"), field + ".heading_deg") * kDeg;
  return pose;
}

OrderedJson attitudeJson(const RoverAttitude& a) {
  return {{"roll_deg", a.roll_rad / kDeg}, {"pitch_deg", a.pitch_rad / kDeg}};
}

// {"roll_deg": r, "pitch_deg": p} (optional member `key` of `object`).
std::optional<RoverAttitude> readAttitude(const JsonFieldReader& r, const Json& object,
                                          const std::string& key, const std::string& field) {
  if (!object.contains(key) || object[key].is_null()) return std::nullopt;
  const Json& j = object[key];
  if (!j.is_object()) r.fail(field, "expected an object {\"roll_deg\": r, \"pitch_deg\": p}");
  RoverAttitude a;
  a.roll_rad = r.number(member(r, j, "roll_deg", field + ".roll_deg"), field + ".roll_deg") * kDeg;
  a.pitch_rad = r.number(member(r, j, "pitch_deg", field + ".pitch_deg"), field + ".pitch_deg") * kDeg;
  if (!(std::fabs(a.roll_rad) < 0.5 * M_PI && std::fabs(a.pitch_rad) < 0.5 * M_PI))
    r.fail(field, "roll and pitch must lie within +-90 degrees");
  return a;
}

double positive(const JsonFieldReader& r, const Json& j, const std::string& field) {
  const double v = r.number(j, field);
  if (!(v > 0.0)) r.fail(field, "must be positive");
  return v;
}

OdometryLeg readLeg(const JsonFieldReader& r, const Json& j, const std::string& field) {
  if (!j.is_object())
    r.fail(field, "expected an object (from, delta_m, delta_heading_deg, distance_m, sigmas)");
  OdometryLeg leg;
  leg.from = r.string(member(r, j, "from", field + ".from"), field + ".from");
  leg.delta_m = r.vec3(member(r, j, "delta_m", field + ".delta_m"), field + ".delta_m");
  leg.delta_heading_rad = r.number(member(r, j, "delta_heading_deg", field + ".delta_heading_deg"),
                                   field + ".delta_heading_deg") *
                          kDeg;
  leg.distance_m = positive(r, member(r, j, "distance_m", field + ".distance_m"), field + ".distance_m");
  leg.sigma_m = r.vec3(member(r, j, "sigma_m", field + ".sigma_m"), field + ".sigma_m");
  for (int k = 0; k < 3; ++k) {
    if (!(leg.sigma_m[k] > 0.0)) r.fail(field + ".sigma_m[" + std::to_string(k) + "]", "must be positive");
  }
  leg.sigma_heading_rad = positive(r, member(r, j, "sigma_heading_deg", field + ".sigma_heading_deg"),
                                   field + ".sigma_heading_deg") *
                          kDeg;
  return leg;
}

// A site id: a non-empty name that is also a safe folder name (letters, digits, '_', '-').
void checkId(const JsonFieldReader& r, const std::string& id, const std::string& field) {
  if (id.empty()) r.fail(field, "empty id");
  for (char ch : id) {
    if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '_' && ch != '-') {
      r.fail(field, "'" + id + "': only letters, digits, '_' and '-' are allowed");
    }
  }
}

TraverseSite readSite(const JsonFieldReader& r, const Json& j, std::size_t index, const Traverse& t,
                      std::set<std::string>& ids, std::set<std::string>& paths) {
  const std::string field = "sites[" + std::to_string(index) + "]";
  if (!j.is_object()) r.fail(field, "expected an object (id, path, apriori, odometry)");
  TraverseSite site;
  site.id = r.string(member(r, j, "id", field + ".id"), field + ".id");
  checkId(r, site.id, field + ".id");
  if (!ids.insert(site.id).second) r.fail(field + ".id", "duplicate id '" + site.id + "'");
  site.path = r.safePath(member(r, j, "path", field + ".path"), field + ".path");
  const std::string normal = std::filesystem::path(site.path).lexically_normal().string();
  if (!paths.insert(normal).second) r.fail(field + ".path", "'" + site.path + "' is used by another site");
  site.dir = resolvePath(t.root, site.path);
  if (j.contains("kind")) {
    const std::string kind = r.string(j["kind"], field + ".kind");
    if (kind == siteKindName(SiteKind::kStop)) {
      site.kind = SiteKind::kStop;
    } else if (kind != siteKindName(SiteKind::kPanorama)) {
      r.fail(field + ".kind", "'" + kind + "': expected \"panorama\" or \"stop\"");
    }
  }
  site.apriori = readPose(r, member(r, j, "apriori", field + ".apriori"), field + ".apriori");
  site.attitude = readAttitude(r, j, "attitude", field + ".attitude");
  if (site.attitude) {
    const Json& a = j["attitude"];
    const std::string sigma = field + ".attitude.sigma_deg";
    site.attitude_sigma_rad = r.number(member(r, a, "sigma_deg", sigma), sigma) * kDeg;
    if (!(site.attitude_sigma_rad >= 0.0)) r.fail(sigma, "must not be negative");
  }
  const bool has_leg = j.contains("odometry") && !j["odometry"].is_null();
  if (index == 0) {
    if (has_leg)
      r.fail(field + ".odometry", "the first site has no odometry (it defines the traverse frame)");
    if (!site.apriori.isIdentity()) {
      r.fail(field + ".apriori", "the first site's pose must be the identity (position 0 0 0, heading 0)");
    }
    return site;
  }
  if (!has_leg) r.fail(field + ".odometry", "missing (required for every site after the first)");
  site.odometry = readLeg(r, j["odometry"], field + ".odometry");
  const std::string& previous = t.sites.back().id;
  if (site.odometry->from != previous) {
    r.fail(field + ".odometry.from",
           "'" + site.odometry->from + "': the odometry must come from the site before, '" + previous + "'");
  }
  return site;
}

}  // namespace

Eigen::Matrix3d RoverAttitude::rotation() const {
  return (Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

const char* siteKindName(SiteKind kind) {
  return kind == SiteKind::kStop ? "stop" : "panorama";
}

Eigen::Matrix3d SitePose::rotation() const {
  return Eigen::AngleAxisd(heading_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

Eigen::Vector3d SitePose::toTraverse(const Eigen::Vector3d& site_m) const {
  return rotation() * site_m + position_m;
}

Eigen::Vector3d SitePose::toSite(const Eigen::Vector3d& traverse_m) const {
  return rotation().transpose() * (traverse_m - position_m);
}

double Traverse::distanceDrivenM() const {
  double sum = 0.0;
  for (const TraverseSite& s : sites) {
    if (s.odometry) sum += s.odometry->distance_m;
  }
  return sum;
}

int Traverse::indexOf(const std::string& id) const {
  for (std::size_t i = 0; i < sites.size(); ++i) {
    if (sites[i].id == id) return static_cast<int>(i);
  }
  return -1;
}

Traverse readTraverse(const std::string& dir) {
  const std::string file = fileIn(dir, kTraverseFileName);
  const JsonFieldReader r(file);
  const Json root = parseJsonFile(r, file);
  Traverse t;
  t.root = file == dir ? std::filesystem::path(dir).parent_path().string() : dir;
  t.version = r.integer(member(r, root, "version", "version"), "version");
  if (t.version != kTraverseVersion) {
    r.fail("version", std::to_string(t.version) + " is not supported (this reader knows version " +
                          std::to_string(kTraverseVersion) + ")");
  }
  t.name = root.contains("name") && !root["name"].is_null() ? r.string(root["name"], "name") : std::string();
  const Json& odometry = member(r, root, "odometry", "odometry");
  if (!odometry.is_object()) r.fail("odometry", "expected an object");
  t.drift_fraction = positive(r, member(r, odometry, "drift_fraction", "odometry.drift_fraction"),
                              "odometry.drift_fraction");
  t.vertical_drift_fraction =
      positive(r, member(r, odometry, "vertical_drift_fraction", "odometry.vertical_drift_fraction"),
               "odometry.vertical_drift_fraction");
  t.heading_sigma_rad = positive(r, member(r, odometry, "heading_sigma_deg", "odometry.heading_sigma_deg"),
                                 "odometry.heading_sigma_deg") *
                        kDeg;
  const Json& sites = member(r, root, "sites", "sites");
  if (!sites.is_array()) r.fail("sites", "expected an array of sites in driving order");
  if (sites.empty()) r.fail("sites", "empty: at least one site is needed");
  std::set<std::string> ids, paths;
  for (std::size_t i = 0; i < sites.size(); ++i) t.sites.push_back(readSite(r, sites[i], i, t, ids, paths));
  return t;
}

void checkTraverseSites(const Traverse& t) {
  const std::string file = joinPath(t.root, kTraverseFileName);
  for (std::size_t i = 0; i < t.sites.size(); ++i) {
    std::error_code ec;
    const std::string panorama = joinPath(t.sites[i].dir, kPanoramaFileName);
    if (!std::filesystem::is_regular_file(panorama, ec)) {
      throw DatasetError(file, "sites[" + std::to_string(i) + "].path",
                         "'" + t.sites[i].path + "' holds no " + kPanoramaFileName + " (" + panorama + ")");
    }
  }
}

void writeTraverse(const Traverse& t, const std::string& dir) {
  OrderedJson root = OrderedJson::object();
  root["version"] = t.version;
  if (!t.name.empty()) root["name"] = t.name;
  root["frame"] =
      "traverse frame = the first site's frame: +X north, +Y east, +Z down, metres; p_traverse = "
      "Rz(heading) p_site + position_m, heading clockwise from north";
  root["odometry"] = {{"drift_fraction", t.drift_fraction},
                      {"vertical_drift_fraction", t.vertical_drift_fraction},
                      {"heading_sigma_deg", t.heading_sigma_rad / kDeg}};
  root["distance_m"] = t.distanceDrivenM();
  OrderedJson sites = OrderedJson::array();
  for (const TraverseSite& s : t.sites) {
    OrderedJson j = {{"id", s.id}, {"path", s.path}};
    if (s.kind != SiteKind::kPanorama) j["kind"] = siteKindName(s.kind);
    j["apriori"] = poseJson(s.apriori);
    if (s.attitude) {
      j["attitude"] = attitudeJson(*s.attitude);
      j["attitude"]["sigma_deg"] = s.attitude_sigma_rad / kDeg;
    }
    if (s.odometry) {
      const OdometryLeg& leg = *s.odometry;
      j["odometry"] = {{"from", leg.from},
                       {"delta_m", vec3Json(leg.delta_m)},
                       {"delta_heading_deg", leg.delta_heading_rad / kDeg},
                       {"distance_m", leg.distance_m},
                       {"sigma_m", vec3Json(leg.sigma_m)},
                       {"sigma_heading_deg", leg.sigma_heading_rad / kDeg}};
    }
    sites.push_back(j);
  }
  root["sites"] = sites;
  writeJsonFile(dir, joinPath(dir, kTraverseFileName), root.dump(2));
}

std::optional<TraverseTruth> readTraverseTruth(const std::string& dir, const Traverse& traverse) {
  const std::string file = joinPath(dir, kTraverseTruthFile);
  std::error_code ec;
  if (!std::filesystem::exists(file, ec)) return std::nullopt;
  const JsonFieldReader r(file);
  const Json root = parseJsonFile(r, file);
  const Json& sites = member(r, root, "sites", "sites");
  if (!sites.is_array()) r.fail("sites", "expected an array of {id, pose}");
  if (sites.size() != traverse.sites.size()) {
    r.fail("sites", std::to_string(sites.size()) + " sites, but " + kTraverseFileName + " has " +
                        std::to_string(traverse.sites.size()));
  }
  TraverseTruth truth;
  for (std::size_t i = 0; i < sites.size(); ++i) {
    const std::string field = "sites[" + std::to_string(i) + "]";
    if (!sites[i].is_object()) r.fail(field, "expected an object {id, pose}");
    const std::string id = r.string(member(r, sites[i], "id", field + ".id"), field + ".id");
    if (id != traverse.sites[i].id) {
      r.fail(field + ".id",
             "'" + id + "' where " + kTraverseFileName + " has '" + traverse.sites[i].id + "'");
    }
    truth.ids.push_back(id);
    truth.poses.push_back(readPose(r, member(r, sites[i], "pose", field + ".pose"), field + ".pose"));
    truth.attitudes.push_back(readAttitude(r, sites[i], "attitude", field + ".attitude"));
  }
  if (root.contains("terrain") && root["terrain"].is_object() && root["terrain"].contains("max_slope_deg"))
    truth.max_slope_deg = r.number(root["terrain"]["max_slope_deg"], "terrain.max_slope_deg");
  return truth;
}

void writeTraverseTruth(const TraverseTruth& truth, const std::string& dir) {
  OrderedJson root = OrderedJson::object();
  root["version"] = kTraverseVersion;
  if (truth.max_slope_deg > 0.0) root["terrain"] = {{"max_slope_deg", truth.max_slope_deg}};
  OrderedJson sites = OrderedJson::array();
  for (std::size_t i = 0; i < truth.poses.size(); ++i) {
    OrderedJson site = {{"id", truth.ids[i]}, {"pose", poseJson(truth.poses[i])}};
    if (i < truth.attitudes.size() && truth.attitudes[i])
      site["attitude"] = attitudeJson(*truth.attitudes[i]);
    sites.push_back(site);
  }
  root["sites"] = sites;
  writeJsonFile(joinPath(dir, kTruthFolder), joinPath(dir, kTraverseTruthFile), root.dump(2));
}

}  // namespace areomap
