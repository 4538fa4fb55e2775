#include "ground/sim/SimGeometry.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include "ground/sim/Noise.hpp"
#include "ground/sim/Parallel.hpp"

namespace areomap::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kCheckPointMarginPx = 0.0;  // every image that sees the point, up to its edge
constexpr double kMaxRayMismatchRad = 1e-6;  // pixel ray vs. direction to the point
constexpr double kMinIncidenceDeg = 8.0;     // grazing views are not check points
constexpr int kCheckPointBatch = 2048;       // candidates per parallel batch (deterministic order)
constexpr int kMaxCandidatesPerPoint = 60;   // bound of the candidate search

Eigen::Matrix3d rotZ(double a) {
  Eigen::Matrix3d r;
  r << std::cos(a), -std::sin(a), 0.0, std::sin(a), std::cos(a), 0.0, 0.0, 0.0, 1.0;
  return r;
}

Eigen::Matrix3d rotY(double a) {
  Eigen::Matrix3d r;
  r << std::cos(a), 0.0, std::sin(a), 0.0, 1.0, 0.0, -std::sin(a), 0.0, std::cos(a);
  return r;
}

// site_from_head for a head pan/tilt.
Eigen::Matrix3d headRotation(double pan_rad, double tilt_rad) {
  return rotZ(pan_rad) * rotY(tilt_rad);
}

// A camera fixed on the head: centre in the head frame and rotation head -> camera (rows H', -V', -A).
struct HeadCamera {
  Eigen::Vector3d position_head;
  Eigen::Matrix3d camera_from_head;
};

HeadCamera headCamera(const SimConfig& c, bool right) {
  const double side = right ? 1.0 : -1.0;
  const double toe = -side * c.toe_in_deg * kDeg;  // left yaws right (+), right yaws left (-)
  HeadCamera cam;
  cam.position_head = Eigen::Vector3d(c.head_forward_m, side * 0.5 * c.base_m, -c.head_up_m);
  const Eigen::Vector3d a(std::cos(toe), std::sin(toe), 0.0);
  const Eigen::Vector3d h(-std::sin(toe), std::cos(toe), 0.0);
  const Eigen::Vector3d v(0.0, 0.0, 1.0);
  cam.camera_from_head.row(0) = h.transpose();
  cam.camera_from_head.row(1) = -v.transpose();
  cam.camera_from_head.row(2) = -a.transpose();
  return cam;
}

// A camera of the head at its true and a-priori pointing. `tilt_axis_*` is the site-frame offset of the tilt
// axis from the gimbal centre (zero unless the mast is FIDO-like), turned by the pan alone.
SimCamera placeCamera(const SimConfig& c, const Eigen::Vector3d& gimbal,
                      const Eigen::Vector3d& gimbal_apriori, const Eigen::Matrix3d& head_true,
                      const Eigen::Matrix3d& head_apriori, const Eigen::Vector3d& tilt_axis_true,
                      const Eigen::Vector3d& tilt_axis_apriori, bool right, const std::string& stem) {
  const HeadCamera hc = headCamera(c, right);
  const double f = c.focalPx();
  const double x0 = 0.5 * (c.width - 1) + (right ? 1.1 : 2.3);
  const double y0 = 0.5 * (c.height - 1) + (right ? -0.6 : -1.7);
  SimCamera cam;
  cam.stem = stem;
  cam.site_to_camera = hc.camera_from_head * head_true.transpose();
  cam.truth = makeCahvor(gimbal + tilt_axis_true + head_true * hc.position_head, cam.site_to_camera, f, x0,
                         y0, c.o_tilt_deg, c.rho1, c.rho2, c.width, c.height);
  cam.apriori = makeCahvor(gimbal_apriori + tilt_axis_apriori + head_apriori * hc.position_head,
                           hc.camera_from_head * head_apriori.transpose(), f, x0, y0, c.o_tilt_deg, c.rho1,
                           c.rho2, c.width, c.height);
  return cam;
}

std::string stemOf(int index, bool right) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "p%03d_%c", index, right ? 'R' : 'L');
  return buffer;
}

}  // namespace

CameraModel makeCahvor(const Eigen::Vector3d& centre_m, const Eigen::Matrix3d& site_to_camera, double f_px,
                       double x0_px, double y0_px, double o_tilt_deg, double rho1, double rho2, int width,
                       int height) {
  const Eigen::Vector3d h_unit = site_to_camera.row(0).transpose();
  const Eigen::Vector3d v_unit = -site_to_camera.row(1).transpose();
  const Eigen::Vector3d a = -site_to_camera.row(2).transpose();
  CameraModel m;
  m.type = CameraType::kCahvor;
  m.c = centre_m;
  m.a = a;
  m.h = f_px * h_unit + x0_px * a;
  m.v = f_px * v_unit + y0_px * a;
  // O: A tilted by o_tilt about the (H' + V') diagonal, like a real lens axis slightly off the boresight.
  const Eigen::Vector3d axis = (h_unit + v_unit).normalized();
  m.o = Eigen::AngleAxisd(o_tilt_deg * kDeg, axis) * a;
  m.r = Eigen::Vector3d(0.0, rho1, rho2);
  m.width = width;
  m.height = height;
  return m;
}

bool pointVisible(const Terrain& terrain, const CameraModel& model, const Eigen::Vector3d& point_m,
                  double margin_px, Vec2& pixel) {
  if (project(model, point_m, pixel) != Status::kOk) return false;
  if (pixel.x() < margin_px || pixel.y() < margin_px || pixel.x() > model.width - 1 - margin_px ||
      pixel.y() > model.height - 1 - margin_px) {
    return false;
  }
  const Eigen::Vector3d d = point_m - model.c;
  const double dist = d.norm();
  const Eigen::Vector3d dir = d / dist;
  // CAHVOR's polynomial folds points far outside the field of view back into the image: the pixel's own
  // ray must point at the point.
  Vec3 origin, ray;
  if (unproject(model, pixel, origin, ray) != Status::kOk || ray.dot(dir) < std::cos(kMaxRayMismatchRad))
    return false;
  const Eigen::Vector3d n = terrain.normal(point_m.x(), point_m.y());
  if (-n.dot(dir) < std::sin(kMinIncidenceDeg * kDeg)) return false;  // back-facing or grazing
  double t_hit = 0.0;
  const double tolerance = std::max(0.003, 0.002 * dist);
  if (terrain.castRay(model.c, dir, t_hit, dist + 0.05) && t_hit < dist - tolerance) return false;
  return true;
}

int camerasSeeingBeyondTerrain(const SimGeometry& g, const Terrain& terrain) {
  constexpr int kSamples = 9;  // along the top row and the upper corners of each image
  int count = 0;
  for (const SimCamera* cam : g.cameras()) {
    const CameraModel truth = g.inTerrain(cam->truth);
    bool beyond = false;
    for (int k = 0; k < kSamples && !beyond; ++k) {
      const Vec2 pixel((truth.width - 1) * k / (kSamples - 1.0), 0.0);
      Vec3 origin, dir;
      double t = 0.0;
      if (unproject(truth, pixel, origin, dir) == Status::kOk && dir.z() > 0.0 &&
          !terrain.castRay(origin, dir, t)) {
        beyond = true;
      }
    }
    if (beyond) ++count;
  }
  return count;
}

std::vector<const SimCamera*> SimGeometry::cameras() const {
  std::vector<const SimCamera*> all;
  for (const SimPair& p : pairs) {
    all.push_back(&p.left);
    if (p.right) all.push_back(&*p.right);
  }
  return all;
}

CameraModel SimGeometry::inTerrain(const CameraModel& model) const {
  if (!terrain_from_site) return model;
  const Eigen::Matrix3d rotation = terrain_from_site->rotation();
  return movedModel(model, rotation, terrain_from_site->toTraverse(model.c));
}

Dataset SimGeometry::dataset(const std::string& root) const {
  Dataset ds;
  ds.root = root;
  ds.name = name.empty() ? "sim-" + config.preset + "-" + std::to_string(config.seed) : name;
  ds.width = config.width;
  ds.height = config.height;
  // A FIDO-like mast has no fixed camera offset from one gimbal point: only the stereo base is given.
  if (config.tilt_axis_forward_m == 0.0) {
    ds.rig.gimbal_m[config.sol] = apriori_gimbal_m;
    ds.rig.left_offset_m = left_offset_m;
    ds.rig.right_offset_m = right_offset_m;
  }
  ds.rig.base_m = base_m;
  // The simulated rig is exactly rigid: every true model satisfies Eq. 3 and Eq. 4 to rounding, so the
  // constraints are written as the paper's pseudo-observations with very small variances (§3.2): 10 um,
  // the starting sigma of a held constraint (firmware_core/adjust/Network.hpp), but given, so not tightened.
  // A dataset without sigmas gets the held rule instead (ground/dataset/RigSigmas.hpp).
  constexpr double kSimSigmaRig_m = 1e-5;
  if (config.tilt_axis_forward_m == 0.0) ds.rig.sigma_gimbal_m = kSimSigmaRig_m;
  ds.rig.sigma_base_m = kSimSigmaRig_m;
  for (const SimPair& p : pairs) {
    Pair pair;
    pair.id = p.id;
    pair.sol = p.sol;
    pair.tier = p.tier;
    pair.left = makeImageRef(root, "images/" + p.left.stem + ".png", "models/" + p.left.stem + ".cahvor");
    if (p.right)
      pair.right =
          makeImageRef(root, "images/" + p.right->stem + ".png", "models/" + p.right->stem + ".cahvor");
    ds.pairs.push_back(pair);
  }
  return ds;
}

SimGeometry makeGeometry(const SimConfig& config) {
  validatePlan(config);
  const Terrain terrain = Terrain::build(config);
  return makeGeometry(config, terrain);
}

SimGeometry makeGeometry(const SimConfig& config, const Terrain& terrain,
                         const std::optional<SitePose>& terrain_from_site,
                         const std::optional<RoverStance>& stance) {
  validatePlan(config);
  SimGeometry g;
  g.config = config;
  g.terrain_from_site = terrain_from_site;
  if (terrain_from_site) g.stance = stance;
  // Site-frame directions of the rover's frame at its true and a-priori attitude (the identity when level;
  // not multiplied then, so that a level site's files stay bit for bit as they were).
  const Eigen::Matrix3d rover_true = g.stance ? g.stance->truth.rotation() : Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d rover_apriori = g.stance ? g.stance->apriori.rotation() : Eigen::Matrix3d::Identity();
  auto onRover = [&](const Eigen::Matrix3d& rover, const Eigen::Matrix3d& m) -> Eigen::Matrix3d {
    return g.stance ? Eigen::Matrix3d(rover * m) : m;
  };
  auto onRoverV = [&](const Eigen::Matrix3d& rover, const Eigen::Vector3d& v) -> Eigen::Vector3d {
    return g.stance ? Eigen::Vector3d(rover * v) : v;
  };
  // The gimbal stands mast_m above the ground under the site origin (the rover); on sloped ground mast_m
  // above its base along its up axis.
  if (g.stance) {
    const Eigen::Vector3d base(0.0, 0.0, -g.stance->base_elevation_m - terrain_from_site->position_m.z());
    const Eigen::Vector3d mast(0.0, 0.0, -config.mast_m);
    g.gimbal_m = base + rover_true * mast;
    g.apriori_gimbal_m = base + rover_apriori * mast;
  } else if (terrain_from_site) {
    const Eigen::Vector3d& site = terrain_from_site->position_m;
    g.gimbal_m =
        Eigen::Vector3d(0.0, 0.0, -(terrain.elevation(site.x(), site.y()) + config.mast_m) - site.z());
  } else {
    g.gimbal_m = Eigen::Vector3d(0.0, 0.0, -(terrain.elevation(0.0, 0.0) + config.mast_m));
  }
  if (!g.stance) g.apriori_gimbal_m = g.gimbal_m;
  const HeadCamera left = headCamera(config, false), right = headCamera(config, true);
  g.left_offset_m = left.camera_from_head * left.position_head;
  g.right_offset_m = right.camera_from_head * right.position_head;
  g.base_m = left.camera_from_head * (right.position_head - left.position_head);

  const double f = config.focalPx();
  int index = 0;
  for (std::size_t tier = 0; tier < config.tiers.size(); ++tier) {
    const TierPlan& plan = config.tiers[tier];
    for (int k = 0; k < plan.pairs; ++k, ++index) {
      SimPair p;
      p.id = index;
      p.sol = config.sol;
      p.tier = static_cast<int>(tier);
      p.pan_deg = plan.pan0_deg + k * plan.pan_step_deg;
      p.tilt_deg = plan.tilt_deg;
      // Pointing error of the head: magnitude in [min, max] pixels at the image centre, random direction.
      std::mt19937_64 rng(hash3(config.seed, 0x9017, index));
      std::uniform_real_distribution<double> u(0.0, 1.0);
      p.pointing_error_px =
          config.pointing_min_px + u(rng) * (config.pointing_max_px - config.pointing_min_px);
      const double direction = 2.0 * M_PI * u(rng);
      p.tilt_error_rad = p.pointing_error_px / f * std::sin(direction);
      p.pan_error_rad = p.pointing_error_px / f * std::cos(direction) / std::cos(p.tilt_deg * kDeg);
      const Eigen::Matrix3d head_true =
          onRover(rover_true, headRotation(p.pan_deg * kDeg, p.tilt_deg * kDeg));
      const Eigen::Matrix3d head_apriori =
          onRover(rover_apriori,
                  headRotation(p.pan_deg * kDeg + p.pan_error_rad, p.tilt_deg * kDeg + p.tilt_error_rad));
      const Eigen::Vector3d forward(config.tilt_axis_forward_m, 0.0, 0.0);
      const Eigen::Vector3d axis_true = onRoverV(rover_true, rotZ(p.pan_deg * kDeg) * forward);
      const Eigen::Vector3d axis_apriori =
          onRoverV(rover_apriori, rotZ(p.pan_deg * kDeg + p.pan_error_rad) * forward);
      p.left = placeCamera(config, g.gimbal_m, g.apriori_gimbal_m, head_true, head_apriori, axis_true,
                           axis_apriori, false, stemOf(index, false));
      if (!plan.left_only) {
        p.right = placeCamera(config, g.gimbal_m, g.apriori_gimbal_m, head_true, head_apriori, axis_true,
                              axis_apriori, true, stemOf(index, true));
      }
      g.pairs.push_back(std::move(p));
    }
  }

  // Check points: candidates on the surface, log-uniform in range about the gimbal, uniform in azimuth;
  // kept when two or more images see them. Batches run in parallel, results are taken in candidate order.
  // The search runs on the terrain (the true models there); the points are kept in the site frame.
  const std::vector<const SimCamera*> cams = g.cameras();
  std::vector<CameraModel> truth_on_terrain;
  for (const SimCamera* cam : cams) truth_on_terrain.push_back(g.inTerrain(cam->truth));
  const Eigen::Vector3d gimbal_on_terrain =
      terrain_from_site ? terrain_from_site->toTraverse(g.gimbal_m) : g.gimbal_m;
  const int wanted = config.check_points;
  const int64_t max_candidates = static_cast<int64_t>(kMaxCandidatesPerPoint) * std::max(wanted, 100);
  struct Candidate {
    Eigen::Vector3d point;
    std::vector<std::pair<int, Vec2>> seen;
  };
  std::vector<Candidate> batch(kCheckPointBatch);
  const double log_min = std::log(config.min_range_m), log_max = std::log(config.max_range_m);
  for (int64_t first = 0; static_cast<int>(g.points.size()) < wanted && first < max_candidates;
       first += kCheckPointBatch) {
    parallelFor(kCheckPointBatch, config.threads, [&](int i) {
      Candidate& c = batch[static_cast<std::size_t>(i)];
      c.seen.clear();
      const uint64_t h = hash3(config.seed, 0xc4ec, first + i);
      const double range = std::exp(log_min + unit(mix64(h + 1)) * (log_max - log_min));
      const double azimuth = 2.0 * M_PI * unit(mix64(h + 2));
      const double x = gimbal_on_terrain.x() + range * std::cos(azimuth),
                   y = gimbal_on_terrain.y() + range * std::sin(azimuth);
      if (!terrain.inside(x, y)) return;
      c.point = Eigen::Vector3d(x, y, -terrain.elevation(x, y));
      for (std::size_t k = 0; k < cams.size(); ++k) {
        Vec2 pixel;
        if (pointVisible(terrain, truth_on_terrain[k], c.point, kCheckPointMarginPx, pixel)) {
          c.seen.emplace_back(static_cast<int>(k), pixel);
        }
      }
    });
    for (int i = 0; i < kCheckPointBatch && static_cast<int>(g.points.size()) < wanted; ++i) {
      const Candidate& c = batch[static_cast<std::size_t>(i)];
      if (c.seen.size() < 2) continue;
      CheckPoint cp;
      cp.point = static_cast<int64_t>(g.points.size());
      cp.site_m = terrain_from_site ? terrain_from_site->toSite(c.point) : c.point;
      g.points.push_back(cp);
      for (const auto& [k, pixel] : c.seen) {
        ImageObservation o;
        o.point = cp.point;
        o.image = cams[static_cast<std::size_t>(k)]->stem;
        o.sample_px = pixel.x();
        o.line_px = pixel.y();
        g.observations.push_back(o);
      }
    }
  }
  return g;
}

}  // namespace areomap::sim
