#include <cmath>
#include <map>
#include <set>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/sim/SimGeometry.hpp"
#include "ground/sim/Terrain.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using namespace areomap::sim;

namespace {

// The photogrammetric rotation of a CAHV(OR) model, computed independently of the simulator: rows
// H' = (H - hc A)/hs, -V' with V' = (V - vc A)/vs, and -A.
Eigen::Matrix3d rotationOf(const CameraModel& m) {
  const double hc = m.a.dot(m.h), vc = m.a.dot(m.v);
  const Eigen::Vector3d hp = (m.h - hc * m.a).normalized(), vp = (m.v - vc * m.a).normalized();
  Eigen::Matrix3d r;
  r.row(0) = hp.transpose();
  r.row(1) = -vp.transpose();
  r.row(2) = -m.a.transpose();
  return r;
}

// One tiny terrain and geometry for the whole group (building them is the slow part).
const Terrain& tinyTerrain() {
  static const Terrain t = Terrain::build(presetConfig("tiny"));
  return t;
}

const SimGeometry& tinyGeometry() {
  static const SimGeometry g = makeGeometry(presetConfig("tiny"), tinyTerrain());
  return g;
}

}  // namespace

TEST_GROUP(SimGeometry){};

TEST(SimGeometry, TrueAndAprioriModelsSatisfyEq3AndEq4) {
  const SimGeometry& g = tinyGeometry();
  CHECK(g.pairs.size() >= 8u);
  double worst_true = 0.0, worst_apriori = 0.0;
  for (const SimPair& p : g.pairs) {
    CHECK(p.right.has_value());
    for (int which = 0; which < 2; ++which) {
      const CameraModel& l = which == 0 ? p.left.truth : p.left.apriori;
      const CameraModel& r = which == 0 ? p.right->truth : p.right->apriori;
      const Eigen::Matrix3d ml = rotationOf(l), mr = rotationOf(r);
      // Eq. 3: X0 = XG + R^T offset, for left and right.
      const double e3l = (l.c - (g.gimbal_m + ml.transpose() * g.left_offset_m)).norm();
      const double e3r = (r.c - (g.gimbal_m + mr.transpose() * g.right_offset_m)).norm();
      // Eq. 4: C_R - C_L = R_L^T base.
      const double e4 = ((r.c - l.c) - ml.transpose() * g.base_m).norm();
      double& worst = which == 0 ? worst_true : worst_apriori;
      worst = std::max({worst, e3l, e3r, e4});
    }
  }
  printf("\nEq.3/Eq.4 worst residual: true %.3g m, a-priori %.3g m (tolerance 1e-9 m)\n", worst_true, worst_apriori);
  CHECK(worst_true < 1e-9);
  CHECK(worst_apriori < 1e-9);
  DOUBLES_EQUAL(g.config.base_m, g.base_m.norm(), 1e-12);
}

TEST(SimGeometry, AprioriPointingIsOffByTheRequestedPixels) {
  SimConfig c = presetConfig("tiny");
  c.check_points = 0;
  c.pointing_min_px = 3.0;
  c.pointing_max_px = 15.0;
  const SimGeometry g = makeGeometry(c, tinyTerrain());
  double lo = 1e9, hi = 0.0;
  for (const SimPair& p : g.pairs) {
    // A far point on the true boresight of the left camera lands at the true principal point; the a-priori
    // model puts it off by the pair's pointing error.
    const CameraModel& t = p.left.truth;
    const Eigen::Vector3d far = t.c + 1e5 * t.a;
    Vec2 pt, pa;
    CHECK(project(t, far, pt) == Status::kOk);
    CHECK(project(p.left.apriori, far, pa) == Status::kOk);
    const double error = (pa - pt).norm();
    lo = std::min(lo, error);
    hi = std::max(hi, error);
    DOUBLES_EQUAL(p.pointing_error_px, error, 0.03 * p.pointing_error_px + 0.05);
    CHECK(p.pointing_error_px >= 3.0 && p.pointing_error_px <= 15.0);
  }
  printf("\na-priori pointing error at the image centre: %.2f .. %.2f px (requested 3..15)\n", lo, hi);
}

TEST(SimGeometry, CheckPointsAreOnTheSurfaceAndSeenByTwoOrMoreImages) {
  const SimGeometry& g = tinyGeometry();
  const Terrain& terrain = tinyTerrain();
  printf("\ntiny terrain: %d x %d nodes, %d rocks, %d craters\n", terrain.nodes(), terrain.nodes(),
         terrain.rockCount(), terrain.craterCount());
  CHECK(g.points.size() >= 100u);
  std::map<int64_t, std::set<std::string>> seen;
  for (const ImageObservation& o : g.observations) seen[o.point].insert(o.image);
  std::map<std::string, const CameraModel*> models;
  for (const SimCamera* c : g.cameras()) models[c->stem] = &c->truth;
  int inter = 0;
  double worst_px = 0.0, worst_z = 0.0;
  for (const CheckPoint& p : g.points) {
    CHECK(seen[p.point].size() >= 2u);
    worst_z = std::max(worst_z, std::fabs(-p.site_m.z() - terrain.elevation(p.site_m.x(), p.site_m.y())));
    std::set<std::string> pairs;
    for (const std::string& s : seen[p.point]) pairs.insert(s.substr(0, 4));
    if (pairs.size() >= 2) ++inter;
  }
  for (const ImageObservation& o : g.observations) {
    // The observation's pixel ray points at the check point (no fold-back of far off-axis points).
    Vec3 origin, ray;
    CHECK(unproject(*models.at(o.image), Vec2(o.sample_px, o.line_px), origin, ray) == Status::kOk);
    const Eigen::Vector3d to_point = (g.points[static_cast<std::size_t>(o.point)].site_m - origin).normalized();
    CHECK(ray.dot(to_point) > std::cos(1e-5));
    Vec2 px;
    CHECK(project(*models.at(o.image), g.points[static_cast<std::size_t>(o.point)].site_m, px) == Status::kOk);
    worst_px = std::max(worst_px, (px - Vec2(o.sample_px, o.line_px)).norm());
  }
  printf("check points: %zu, observations %zu, seen by two or more pairs %d; worst reprojection %.2g px, "
         "worst height off the surface %.2g m\n",
         g.points.size(), g.observations.size(), inter, worst_px, worst_z);
  CHECK(inter >= 20);
  CHECK(worst_px < 1e-9);
  CHECK(worst_z < 1e-9);
}

TEST(SimGeometry, RayCastingHitsTheSurfaceAndRocksOcclude) {
  const SimGeometry& g = tinyGeometry();
  const Terrain& terrain = tinyTerrain();
  // Rays from the gimbal down to random surface points: the first hit lies on the surface, and it is never
  // beyond the target; a brute-force march confirms hits and occlusions.
  int hits = 0, occluded = 0, disagree = 0;
  for (int i = 0; i < 200; ++i) {
    const double az = 0.0314 * i * 4.0, range = 2.0 + 0.04 * i;
    const Eigen::Vector3d target(range * std::cos(az), range * std::sin(az), 0.0);
    const Eigen::Vector3d p(target.x(), target.y(), -terrain.elevation(target.x(), target.y()));
    const Eigen::Vector3d d = (p - g.gimbal_m).normalized();
    const double dist = (p - g.gimbal_m).norm();
    double t = 0.0;
    const bool hit = terrain.castRay(g.gimbal_m, d, t, dist + 1.0);
    CHECK(hit);
    if (!hit) continue;
    ++hits;
    const Eigen::Vector3d q = g.gimbal_m + t * d;
    DOUBLES_EQUAL(-q.z(), terrain.elevation(q.x(), q.y()), 1e-6);
    CHECK(t <= dist + 1e-6);
    if (t < dist - 1e-3) ++occluded;
    // Brute force: fine steps of a tenth of a cell; first step below the surface.
    double t_brute = -1.0;
    for (double s = 0.0; s <= dist + 0.5; s += 0.2 * terrain.cellM()) {
      const Eigen::Vector3d r = g.gimbal_m + s * d;
      if (-r.z() <= terrain.elevation(r.x(), r.y())) {
        t_brute = s;
        break;
      }
    }
    if (std::fabs(t_brute - t) > 0.2 * terrain.cellM() / std::max(1e-3, std::fabs(d.z())) + 1e-6) ++disagree;
  }
  printf("\nrays: %d hits, %d occluded before the target, %d disagree with brute force\n", hits, occluded, disagree);
  CHECK(occluded > 0);
  CHECK(disagree <= 2);
}

TEST(SimGeometry, ImpossiblePlansAreRejected) {
  SimConfig c = presetConfig("tiny");
  c.tiers[0].pan_step_deg = 70.0;  // > 60-degree field
  CHECK_THROWS(cli::UsageError, validatePlan(c));
  c = presetConfig("tiny");
  c.tiers[0].tilt_deg = 40.0;  // sees only sky
  CHECK_THROWS(cli::UsageError, validatePlan(c));
  c = presetConfig("tiny");
  CHECK_THROWS(cli::UsageError, setPairCount(c, 0));
  c = presetConfig("tiny");
  setPairCount(c, 200);
  CHECK_THROWS(cli::UsageError, validatePlan(c));
  c = presetConfig("tiny");
  setPairCount(c, 3);  // an arc at the preset's step
  validatePlan(c);
  DOUBLES_EQUAL(45.0, c.tiers[0].pan_step_deg, 1e-12);
  c = presetConfig("imp");
  setPairCount(c, 41);  // 40 over two tiers + the single image
  CHECK_EQUAL(20, c.tiers[0].pairs);
  CHECK_EQUAL(20, c.tiers[1].pairs);
  CHECK_EQUAL(1, c.tiers[2].pairs);
  validatePlan(c);  // too few to close the circle: arcs at the preset's 11.25-degree step
  DOUBLES_EQUAL(11.25, c.tiers[0].pan_step_deg, 1e-12);
  CHECK_THROWS(cli::UsageError, presetConfig("hirise"));
}

TEST(SimGeometry, TheTruthDemCoversAllThatTheCamerasSee) {
  CHECK_EQUAL(0, camerasSeeingBeyondTerrain(tinyGeometry(), tinyTerrain()));
  SimConfig c = presetConfig("tiny");
  c.tiers[0].tilt_deg = -26.0;  // the top row looks ~33 m out: beyond the 20 m fine grid, on the coarse one
  c.check_points = 0;
  CHECK_EQUAL(0, camerasSeeingBeyondTerrain(makeGeometry(c, tinyTerrain()), tinyTerrain()));
  c.tiers[0].tilt_deg = -24.5;  // the top row looks ~60 m out: beyond the 50 m terrain
  CHECK(camerasSeeingBeyondTerrain(makeGeometry(c, tinyTerrain()), tinyTerrain()) > 0);
}

TEST(SimGeometry, EveryPresetsTerrainCoversAtLeast100MBy100M) {
  for (const char* name : {"tiny", "navcam", "imp"}) {
    const SimConfig c = presetConfig(name);
    CHECK(Terrain::coverHalfExtentM(c) >= 50.0);
  }
  const Terrain& t = tinyTerrain();
  CHECK(t.halfExtentM() >= 50.0);
  CHECK(t.coarseNodes() > 0);
  for (double x : {-49.9, 49.9}) {
    for (double y : {-49.9, 49.9}) CHECK(t.inside(x, y));
  }
  // The truth DEM covers the same square, at the fine cell size, and agrees with the surface.
  const DemGrid dem = t.dem();
  CHECK(dem.cols * dem.cell_m >= 100.0 - 1e-6);
  CHECK(dem.rows * dem.cell_m >= 100.0 - 1e-6);
  DOUBLES_EQUAL(t.cellM(), dem.cell_m, 1e-12);
  // The coarse grid continues the relief: across the fine grid's edge the surface has no step beyond the
  // rocks' and the finest octaves' size, and rays far out hit it.
  const double edge = 0.5 * (t.nodes() - 1) * t.cellM();
  double worst = 0.0;
  for (int i = -40; i <= 40; ++i) {
    const double y = i * 0.5;
    worst = std::max(worst, std::fabs(t.elevation(edge - 1e-6, y) - t.elevation(edge + 1e-6, y)));
  }
  printf("\nlargest step across the fine grid edge: %.3f m\n", worst);
  CHECK(worst < 0.5);
  const Eigen::Vector3d origin(0.0, 0.0, -(t.elevation(0.0, 0.0) + 2.0));
  const Eigen::Vector3d dir = Eigen::Vector3d(40.0, 5.0, -(t.elevation(40.0, 5.0)) - origin.z()).normalized();
  double t_hit = 0.0;
  CHECK(t.castRay(origin, dir, t_hit));
  const Eigen::Vector3d hit = origin + t_hit * dir;
  CHECK(std::hypot(hit.x(), hit.y()) > 20.0);
  DOUBLES_EQUAL(t.elevation(hit.x(), hit.y()), -hit.z(), 1e-3);
}

TEST(SimGeometry, RocksFollowGolombeksSizeFrequency) {
  // Closed form of the integral of 4 k q exp(-q D) / (pi D^2) with the exponential integral E1(x) = -Ei(-x).
  const double k = 0.08, q = 1.79 + 0.152 / k, d0 = 0.3, d1 = 2.5;
  auto e1 = [](double x) { return -std::expint(-x); };
  const double exact = 4.0 * k * q / M_PI *
                       (std::exp(-q * d0) / d0 - std::exp(-q * d1) / d1 - q * (e1(q * d0) - e1(q * d1)));
  const double numeric = golombekRockDensity(k, d0, d1);
  printf("\nrocks >= 0.3 m per m^2 (k = 0.08): %.5f numeric, %.5f closed form\n", numeric, exact);
  DOUBLES_EQUAL(exact, numeric, 1e-3 * exact);
  // A terrain whose minimum rock is 0.3 m everywhere holds the expected number (Poisson, 4 sigma).
  SimConfig c = presetConfig("tiny");
  c.min_rock_m = 0.3;
  c.cell_m = 0.06;
  const Terrain t = Terrain::build(c);
  const double expected = numeric * (4.0 * c.half_extent_m * c.half_extent_m - M_PI * 1.6 * 1.6);
  printf("rocks in the 40 m square: %d, expected %.0f +- %.0f\n", t.rockCount(), expected, std::sqrt(expected));
  DOUBLES_EQUAL(expected, t.rockCount(), 4.0 * std::sqrt(expected));
}

TEST(SimGeometry, PresetsHaveTheRequestedShape) {
  const SimConfig navcam = presetConfig("navcam");
  validatePlan(navcam);
  CHECK_EQUAL(18, navcam.pairCount());
  CHECK_EQUAL(1024, navcam.width);
  const SimConfig imp = presetConfig("imp");
  validatePlan(imp);
  CHECK_EQUAL(65, imp.pairCount());
  int images = 0;
  for (const TierPlan& t : imp.tiers) images += t.left_only ? t.pairs : 2 * t.pairs;
  CHECK_EQUAL(129, images);
}
