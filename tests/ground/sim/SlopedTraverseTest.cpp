#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/Traverse.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/io/ImageFile.hpp"
#include "ground/sim/SimGeometry.hpp"
#include "ground/sim/Terrain.hpp"
#include "ground/sim/TraverseSim.hpp"
#include "tests/ground/sim/ImagePatches.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using namespace areomap::sim;
using namespace areomap::sim::patches;

namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kSlopeDeg = 15.0;

// Four sites of tiny panoramas on swells reaching 15 degrees, the IMU at its default sigma.
TraverseSimConfig slopedTraverse() {
  TraverseSimConfig c = traversePreset("tiny");
  c.seed = 9;
  c.traverse.sites = 4;
  c.traverse.leg_min_m = 10.0;
  c.traverse.leg_max_m = 14.0;
  c.traverse.max_slope_deg = kSlopeDeg;
  return c;
}

const std::string& slopedDir() {
  static const std::string dir = [] {
    const std::string d = test::scratchDir("sloped-traverse") + "/traverse";
    (void)writeTraverseDataset(slopedTraverse(), d, TraverseSimOptions{});
    return d;
  }();
  return dir;
}

const Terrain& slopedTerrain() {
  static const Terrain terrain = [] {
    const TraverseSimConfig c = slopedTraverse();
    return Terrain::build(traverseTerrainConfig(c, planTraverse(c.traverse, c.seed)));
  }();
  return terrain;
}

// The rover's down axis in the traverse frame.
Eigen::Vector3d downAxis(const SitePose& pose, const RoverAttitude& attitude) {
  return pose.rotation() * attitude.rotation() * Eigen::Vector3d::UnitZ();
}

// The downward normal of the plane fitted (least squares, Eigen's solver) to an elevation over the rover's
// whole footprint (1.6 m x 1.4 m, 5 cm steps) about a site: independent of the six wheel contacts.
Eigen::Vector3d footprintNormal(const std::function<double(double, double)>& elevation,
                                const SitePose& pose) {
  std::vector<Eigen::Vector3d> rows;
  std::vector<double> heights;
  for (double x = -0.8; x <= 0.8 + 1e-9; x += 0.05) {
    for (double y = -0.7; y <= 0.7 + 1e-9; y += 0.05) {
      const Eigen::Vector3d p = pose.toTraverse(Eigen::Vector3d(x, y, 0.0));
      rows.emplace_back(1.0, p.x(), p.y());
      heights.push_back(elevation(p.x(), p.y()));
    }
  }
  Eigen::MatrixXd a(rows.size(), 3);
  Eigen::VectorXd b(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    a.row(static_cast<Eigen::Index>(i)) = rows[i].transpose();
    b[static_cast<Eigen::Index>(i)] = heights[i];
  }
  const Eigen::Vector3d c = a.colPivHouseholderQr().solve(b);
  return Eigen::Vector3d(c[1], c[2], 1.0).normalized();  // e = c0 + c1 x + c2 y, Z down
}

double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) / kDeg;
}

// The rotation rows [H'; -V'; -A] of a CAHVOR model.
Eigen::Matrix3d slopedRotationOf(const CameraModel& m) {
  const Eigen::Vector3d a = m.a.normalized();
  const Eigen::Vector3d h = (m.h - m.h.dot(a) * a).normalized(), v = (m.v - m.v.dot(a) * a).normalized();
  Eigen::Matrix3d r;
  r.row(0) = h.transpose();
  r.row(1) = -v.transpose();
  r.row(2) = -a.transpose();
  return r;
}

std::string readSlopedFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

RenderedImage loadSlopedRendered(const std::string& path) {
  const cv::Mat m = io::loadImage8(path);
  RenderedImage im;
  im.width = m.cols;
  im.height = m.rows;
  im.pixels.assign(m.data, m.data + static_cast<std::size_t>(m.cols) * m.rows);
  return im;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

TEST_GROUP(SlopedTraverse){};

TEST(SlopedTraverse, EachRoverStandsOnTheTerrainTiltedByItsWheelsWithTheMastAboveItsBase) {
  const std::string& dir = slopedDir();
  const Terrain& terrain = slopedTerrain();
  const Traverse t = readTraverse(dir);
  const TraverseTruth truth = *readTraverseTruth(dir, t);
  CHECK_EQUAL(t.sites.size(), truth.attitudes.size());
  const double mast_m = slopedTraverse().site.mast_m;
  double worst_normal = 0.0, worst_wheel = 0.0, worst_gimbal = 0.0;
  for (std::size_t k = 0; k < t.sites.size(); ++k) {
    CHECK(truth.attitudes[k].has_value());
    const SitePose& pose = truth.poses[k];
    const Eigen::Vector3d down = downAxis(pose, *truth.attitudes[k]);
    worst_normal = std::max(
        worst_normal,
        angleDeg(down, footprintNormal([&](double x, double y) { return terrain.elevation(x, y); }, pose)));
    // The rover's base: on the terrain under its centre, to within the relief under its wheels.
    const Dataset ds = readDataset(t.sites[k].dir);
    const CameraModel left = io::readCameraModelFile(t.sites[k].dir + "/" + kTruthModelsFolder + "/" +
                                                     ds.pairs[0].left.stem + ".cahvor");
    // The true gimbal from a true model and the rig's offset (Eq. 3), in the traverse frame: mast_m above
    // a base point on the rover's up axis, that base within a few cm of the terrain under the centre.
    const Eigen::Vector3d gimbal =
        pose.toTraverse(left.c - slopedRotationOf(left).transpose() * *ds.rig.left_offset_m);
    const Eigen::Vector3d base = gimbal + mast_m * down;
    worst_gimbal = std::max(worst_gimbal, (base.head<2>() - pose.position_m.head<2>()).norm());
    for (const auto& wheel : kWheelContacts) {
      const Eigen::Vector3d p = pose.toTraverse(Eigen::Vector3d(wheel[0], wheel[1], 0.0));
      const Eigen::Vector3d contact(p.x(), p.y(), -terrain.elevation(p.x(), p.y()));
      worst_wheel = std::max(worst_wheel, std::fabs((contact - base).dot(down)));  // off the rover's plane
    }
  }
  printf(
      "\nsloped traverse: rover's up axis vs the footprint's fitted plane: worst %.2f deg; wheel contacts "
      "off the rover's base plane: worst %.3f m; base vs site centre %.2g m\n",
      worst_normal, worst_wheel, worst_gimbal);
  // The six wheels sample the relief of a 1.4 m x 1.2 m footprint (relief_m 0.25 RMS over wavelengths of
  // 32 m down to a few cells): the small-scale relief there tilts a plane through six points from the
  // footprint's best plane by a degree or so, and lifts a wheel a few cm off it.
  CHECK(worst_normal < 2.0);
  CHECK(worst_wheel < 0.05);
  CHECK(worst_gimbal < 1e-6);  // the base stands under the site's centre, exactly
}

TEST(SlopedTraverse, TheSlopesAlongThePathReachTheMaximum) {
  // The swells are a property of the terrain: the sloped terrain minus the same terrain built level is
  // the swells alone where no rock stands (a rock's top follows the ground under its centre, not the swell
  // across it), as under each rover (its rock-free footprint). Fitted over the footprint at every site it
  // reaches S (the swells' steepest circle crosses a site, ground/sim/TraverseSim.cpp) and never exceeds
  // it: margin 0.2 deg for the float32 grid and the footprint's averaging of a 60 m swell. The rovers
  // themselves stand on the swells plus the level terrain's own relief, which alone tilts a rover by
  // 1.6 deg median and 3.2 deg at most over 40 sites of 8 seeds (docs/traverse.md "Sloped ground"): the
  // steepest site is within 3.5 deg of S.
  const std::string& dir = slopedDir();
  const Traverse t = readTraverse(dir);
  const TraverseTruth truth = *readTraverseTruth(dir, t);
  DOUBLES_EQUAL(kSlopeDeg, truth.max_slope_deg, 0.0);
  TraverseSimConfig level_config = slopedTraverse();
  level_config.traverse.max_slope_deg = 0.0;
  const Terrain level = Terrain::build(
      traverseTerrainConfig(level_config, planTraverse(level_config.traverse, level_config.seed)));
  const Terrain& sloped = slopedTerrain();
  auto swell = [&](double x, double y) { return sloped.elevation(x, y) - level.elevation(x, y); };
  double swell_steepest = 0.0;
  for (const SitePose& pose : truth.poses) {
    swell_steepest =
        std::max(swell_steepest, angleDeg(footprintNormal(swell, pose), Eigen::Vector3d::UnitZ()));
  }
  double steepest = 0.0, flattest = 90.0;
  for (std::size_t k = 0; k < t.sites.size(); ++k) {
    const double tilt = angleDeg(downAxis(truth.poses[k], *truth.attitudes[k]), Eigen::Vector3d::UnitZ());
    steepest = std::max(steepest, tilt);
    flattest = std::min(flattest, tilt);
  }
  printf(
      "\nsloped traverse, S = %.0f deg: the swells under the rovers reach %.3f deg; the rovers' tilts "
      "%.2f..%.2f deg\n",
      kSlopeDeg, swell_steepest, flattest, steepest);
  DOUBLES_EQUAL(kSlopeDeg, swell_steepest, 0.2);
  DOUBLES_EQUAL(kSlopeDeg, steepest, 3.5);
}

TEST(SlopedTraverse, TraverseJsonCarriesTheImuAttitudeAndTheTruthTheTrueOne) {
  const std::string& dir = slopedDir();
  const Traverse t = readTraverse(dir);
  const TraverseTruth truth = *readTraverseTruth(dir, t);
  const double sigma = slopedTraverse().traverse.tilt_sigma_deg * kDeg;
  bool differs = false;
  for (std::size_t k = 0; k < t.sites.size(); ++k) {
    CHECK(t.sites[k].attitude.has_value());
    DOUBLES_EQUAL(sigma, t.sites[k].attitude_sigma_rad, 1e-15);
    const double dr = t.sites[k].attitude->roll_rad - truth.attitudes[k]->roll_rad;
    const double dp = t.sites[k].attitude->pitch_rad - truth.attitudes[k]->pitch_rad;
    CHECK(std::fabs(dr) < 5.0 * sigma && std::fabs(dp) < 5.0 * sigma);
    differs = differs || dr != 0.0 || dp != 0.0;
  }
  CHECK(differs);
  // The a-priori models of every site are levelled by that attitude: the rig's gimbal in panorama.json is
  // mast_m above the base along the a-priori up axis, not the true one.
  for (std::size_t k = 0; k < t.sites.size(); ++k) {
    const Dataset ds = readDataset(t.sites[k].dir);
    const CameraModel apriori =
        io::readCameraModelFile(t.sites[k].dir + "/models/" + ds.pairs[0].left.stem + ".cahvor");
    const Eigen::Vector3d gimbal = apriori.c - slopedRotationOf(apriori).transpose() * *ds.rig.left_offset_m;
    CHECK((gimbal - ds.rig.gimbal_m.begin()->second).norm() < 1e-6);
    const Eigen::Vector3d mast = t.sites[k].attitude->rotation() * Eigen::Vector3d(0, 0, -1);
    const Eigen::Vector3d true_mast = truth.attitudes[k]->rotation() * Eigen::Vector3d(0, 0, -1);
    const CameraModel true_left = io::readCameraModelFile(t.sites[k].dir + "/" + kTruthModelsFolder + "/" +
                                                          ds.pairs[0].left.stem + ".cahvor");
    const Eigen::Vector3d true_gimbal =
        true_left.c - slopedRotationOf(true_left).transpose() * *ds.rig.left_offset_m;
    // Both gimbals on their mast from one base: base = gimbal - mast_m * up.
    const double mast_m = slopedTraverse().site.mast_m;
    CHECK(((gimbal - mast_m * mast) - (true_gimbal - mast_m * true_mast)).norm() < 1e-6);
  }
}

TEST(SlopedTraverse, TheTrueModelsSeeWhatTheRendererDrew) {
  // Within each site: the true observations of a check point in two images mark the same surface (every
  // pixel of A's patch cast onto the terrain through the true models and sampled in B). The control: the
  // same with the true models levelled (the rover's attitude taken out, each camera turned about its
  // centre), which looks
  // elsewhere on a 15-degree slope.
  const std::string& dir = slopedDir();
  const Terrain& terrain = slopedTerrain();
  const Traverse t = readTraverse(dir);
  const TraverseTruth truth = *readTraverseTruth(dir, t);
  std::vector<double> values, control;
  for (std::size_t k = 0; k < t.sites.size(); ++k) {
    const SitePose& pose = truth.poses[k];
    const Dataset ds = readDataset(t.sites[k].dir);
    const Eigen::Matrix3d attitude = truth.attitudes[k]->rotation();
    std::map<std::string, CameraModel> models, levelled;
    std::map<std::string, RenderedImage> images;
    for (const Pair& p : ds.pairs) {
      for (const ImageRef* side : {&p.left, &*p.right}) {
        const CameraModel m =
            io::readCameraModelFile(t.sites[k].dir + "/" + kTruthModelsFolder + "/" + side->stem + ".cahvor");
        models[side->stem] = movedModel(m, pose.rotation(), pose.toTraverse(m.c));
        const Eigen::Matrix3d back = pose.rotation() * attitude.transpose();
        levelled[side->stem] = movedModel(m, back, pose.toTraverse(m.c));
        images[side->stem] = loadSlopedRendered(side->image_path);
      }
    }
    std::map<int64_t, std::vector<ImageObservation>> by_point;
    for (const ImageObservation& o : readObservationsCsv(t.sites[k].dir + "/" + kTruthObservationsFile)) {
      if (o.sample_px >= 6 && o.line_px >= 6 && o.sample_px <= ds.width - 7 && o.line_px <= ds.height - 7)
        by_point[o.point].push_back(o);
    }
    for (const auto& [point, obs] : by_point) {
      if (obs.size() < 2) continue;
      const Vec2 pa(obs[0].sample_px, obs[0].line_px), pb(obs[1].sample_px, obs[1].line_px);
      double v = 0.0, c = 0.0;
      if (warpedNcc(terrain, models.at(obs[0].image), images.at(obs[0].image), pa, models.at(obs[1].image),
                    images.at(obs[1].image), 5, v) &&
          warpedNcc(terrain, levelled.at(obs[0].image), images.at(obs[0].image), pa,
                    levelled.at(obs[1].image), images.at(obs[1].image), 5, c)) {
        values.push_back(v);
        control.push_back(c);
      }
    }
  }
  printf(
      "\nsloped traverse: 11x11 warped NCC at the true observations: %zu points, median %.3f (levelled "
      "models: %.3f)\n",
      values.size(), values.empty() ? 0.0 : median(values), control.empty() ? 0.0 : median(control));
  CHECK(values.size() >= 200u);
  CHECK(median(values) >= 0.9);
  CHECK(median(control) < 0.5);
}

TEST(SlopedTraverse, AprioriModelsAreTheTrueOnesTurnedAboutTheBaseByTheAttitudeError) {
  // Without pointing errors, each a-priori camera is its true one turned about the rover's base by
  // R_apriori R_true^T; a stance with no tilt standing on the terrain gives the level site's models.
  SimConfig c = presetConfig("tiny");
  c.pointing_min_px = 0.0;
  c.pointing_max_px = 0.0;
  c.check_points = 0;
  const Terrain terrain = Terrain::build(c);
  SitePose pose;
  RoverStance stance;
  stance.truth.roll_rad = 9.0 * kDeg;
  stance.truth.pitch_rad = -6.0 * kDeg;
  stance.apriori.roll_rad = stance.truth.roll_rad + 0.3 * kDeg;
  stance.apriori.pitch_rad = stance.truth.pitch_rad - 0.2 * kDeg;
  stance.base_elevation_m = 0.4;
  const SimGeometry g = makeGeometry(c, terrain, pose, stance);
  const Eigen::Vector3d base(0.0, 0.0, -0.4);
  const Eigen::Matrix3d turn = stance.apriori.rotation() * stance.truth.rotation().transpose();
  for (const SimCamera* cam : g.cameras()) {
    CHECK((cam->apriori.c - base - turn * (cam->truth.c - base)).norm() < 1e-9);
    CHECK((cam->apriori.a - turn * cam->truth.a).norm() < 1e-12);
    CHECK((cam->apriori.h - turn * cam->truth.h).norm() < 1e-9);
  }
  CHECK((g.apriori_gimbal_m - base - turn * (g.gimbal_m - base)).norm() < 1e-12);
  CHECK(std::fabs((g.gimbal_m - base).norm() - c.mast_m) < 1e-12);

  RoverStance level;
  level.base_elevation_m = terrain.elevation(0.0, 0.0);
  level.apriori = level.truth;
  const SimGeometry a = makeGeometry(c, terrain, pose, level), b = makeGeometry(c, terrain, pose);
  const std::vector<const SimCamera*> ca = a.cameras(), cb = b.cameras();
  CHECK_EQUAL(cb.size(), ca.size());
  for (std::size_t i = 0; i < ca.size(); ++i) {
    CHECK((ca[i]->truth.c - cb[i]->truth.c).norm() < 1e-12);
    CHECK((ca[i]->truth.a - cb[i]->truth.a).norm() < 1e-15);
    CHECK((ca[i]->apriori.c - cb[i]->apriori.c).norm() < 1e-12);
  }
}

TEST(SlopedTraverse, TheToolTakesTheSlopeOptionsOnlyForATraverse) {
  const std::string dir = test::scratchDir("sloped-traverse-tool");
  const std::string traverse = "--preset traverse --camera tiny --sites 2 --no-images ";
  CHECK_EQUAL(0, test::runTool("areomap-sim",
                               traverse + "--max-slope-deg 8 --tilt-sigma-deg 0.5 --out " + dir + "/sloped"));
  const Traverse t = readTraverse(dir + "/sloped");
  CHECK(t.sites[1].attitude.has_value());
  DOUBLES_EQUAL(0.5 * kDeg, t.sites[1].attitude_sigma_rad, 1e-15);
  // A level traverse writes no attitude, and its files read as before.
  CHECK_EQUAL(0, test::runTool("areomap-sim", traverse + "--out " + dir + "/level"));
  CHECK(!readTraverse(dir + "/level").sites[1].attitude.has_value());
  CHECK(readSlopedFile(dir + "/level/" + kTraverseFileName).find("attitude") == std::string::npos);
  CHECK(readSlopedFile(dir + "/level/" + kTraverseTruthFile).find("attitude") == std::string::npos);
  CHECK_EQUAL(2, test::runTool("areomap-sim", traverse + "--tilt-sigma-deg 0.5 --out " + dir + "/bad"));
  CHECK_EQUAL(2, test::runTool("areomap-sim", traverse + "--max-slope-deg 50 --out " + dir + "/bad"));
  CHECK_EQUAL(2, test::runTool("areomap-sim", "--preset tiny --max-slope-deg 5 --out " + dir + "/bad"));
  CHECK(!test::fileExists(dir + "/bad/traverse.json"));
  const std::string help = dir + "/help.txt";
  CHECK_EQUAL(0, std::system((test::toolPath("areomap-sim") + " --help > " + help).c_str()));
  const std::string text = readSlopedFile(help);
  CHECK(text.find("--max-slope-deg") != std::string::npos);
  CHECK(text.find("--tilt-sigma-deg") != std::string::npos);
}
