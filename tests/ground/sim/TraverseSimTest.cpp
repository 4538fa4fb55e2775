#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/DemRaster.hpp"
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

constexpr uint64_t kSeed = 5;

// Three sites of tiny panoramas 10-12 m apart (so that a site sees the check points of the next one).
TraverseSimConfig tinyTraverse() {
  TraverseSimConfig c = traversePreset("tiny");
  c.seed = kSeed;
  c.traverse.sites = 3;
  c.traverse.leg_min_m = 10.0;
  c.traverse.leg_max_m = 12.0;
  return c;
}

// The rendered traverse, written once per process.
const std::string& tinyTraverseDir() {
  static const std::string dir = [] {
    const std::string d = test::scratchDir("traverse-sim") + "/traverse";
    (void)writeTraverseDataset(tinyTraverse(), d, TraverseSimOptions{});
    return d;
  }();
  return dir;
}

// Its terrain, built again from the configuration.
const Terrain& tinyTraverseTerrain() {
  static const Terrain terrain = [] {
    const TraverseSimConfig c = tinyTraverse();
    return Terrain::build(traverseTerrainConfig(c, planTraverse(c.traverse, c.seed)));
  }();
  return terrain;
}

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

RenderedImage loadRendered(const std::string& path) {
  const cv::Mat m = io::loadImage8(path);
  RenderedImage im;
  im.width = m.cols;
  im.height = m.rows;
  im.pixels.assign(m.data, m.data + static_cast<std::size_t>(m.cols) * m.rows);
  return im;
}

// A site-frame model on the terrain through a pose.
CameraModel onTerrain(const CameraModel& model, const SitePose& pose) {
  return movedModel(model, pose.rotation(), pose.toTraverse(model.c));
}

// Bilinear elevation of a DEM at a site point (cell centres as the raster contract places them).
double demAt(const DemGrid& dem, double x_north, double y_east) {
  const double u = (y_east - dem.east0_m) / dem.cell_m - 0.5, v = (dem.north0_m - x_north) / dem.cell_m - 0.5;
  const int c = static_cast<int>(std::floor(u)), r = static_cast<int>(std::floor(v));
  if (c < 0 || r < 0 || c + 1 >= dem.cols || r + 1 >= dem.rows) return NAN;
  const double fu = u - c, fv = v - r;
  return dem.at(c, r) * (1 - fu) * (1 - fv) + dem.at(c + 1, r) * fu * (1 - fv) +
         dem.at(c, r + 1) * (1 - fu) * fv + dem.at(c + 1, r + 1) * fu * fv;
}

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(p * (v.size() - 1))];
}

}  // namespace

TEST_GROUP(TraverseSim){};

TEST(TraverseSim, TheLayoutIsCompleteAndEverySiteLoadsAsADataset) {
  const std::string& dir = tinyTraverseDir();
  const Traverse t = readTraverse(dir);
  checkTraverseSites(t);
  CHECK_EQUAL(3, static_cast<int>(t.sites.size()));
  DOUBLES_EQUAL(0.05, t.drift_fraction, 1e-15);
  const std::optional<TraverseTruth> truth = readTraverseTruth(dir, t);
  CHECK(truth.has_value());
  CHECK(truth->poses[0].isIdentity());
  CHECK(test::fileExists(dir + "/" + kTruthDemFile));
  const DemGrid whole = readDemGeoTiff(dir + "/" + kTruthDemFile);
  DOUBLES_EQUAL(kTraverseDemCellM, whole.cell_m, 1e-12);
  for (std::size_t k = 0; k < t.sites.size(); ++k) {
    const TraverseSite& site = t.sites[k];
    STRCMP_EQUAL(traverseSiteId(static_cast<int>(k)).c_str(), site.id.c_str());
    STRCMP_EQUAL(("sites/" + site.id).c_str(), site.path.c_str());
    CHECK_EQUAL(k > 0, site.odometry.has_value());
    const Dataset ds = readDataset(site.dir);
    checkDatasetFiles(ds, true, true);
    CHECK_EQUAL(8, static_cast<int>(ds.pairs.size()));
    CHECK(ds.rig.gimbal_m.size() == 1u && ds.rig.base_m.has_value());
    for (const Pair& p : ds.pairs) {
      CHECK(test::fileExists(site.dir + "/" + kTruthModelsFolder + "/" + p.left.stem + ".cahvor"));
      CHECK(test::fileExists(site.dir + "/" + kTruthModelsFolder + "/" + p.right->stem + ".cahvor"));
    }
    CHECK(readPointsCsv(site.dir + "/" + kTruthPointsFile).size() >= 100u);
    CHECK(!readObservationsCsv(site.dir + "/" + kTruthObservationsFile).empty());
    CHECK(test::fileExists(site.dir + "/truth/sim.json"));
    // The site's truth DEM: its own frame, about its origin, covering what its cameras see.
    const DemGrid dem = readDemGeoTiff(site.dir + "/" + kTruthDemFile);
    CHECK(dem.cols * dem.cell_m >= 2.0 * Terrain::kMinCoverHalfM - 1e-6);
    // The same gimbal in every site's frame: the origins stand as high above the ground as the first.
    DOUBLES_EQUAL(readDataset(t.sites[0].dir).rig.gimbal_m.begin()->second.z(),
                  ds.rig.gimbal_m.begin()->second.z(), 1e-6);
  }
}

TEST(TraverseSim, TruthPosesAreLegsApartAndTheOdometryWithinItsSigmas) {
  const std::string& dir = tinyTraverseDir();
  const Traverse t = readTraverse(dir);
  const TraverseTruth truth = *readTraverseTruth(dir, t);
  for (std::size_t k = 1; k < t.sites.size(); ++k) {
    const OdometryLeg& leg = *t.sites[k].odometry;
    STRCMP_EQUAL(t.sites[k - 1].id.c_str(), leg.from.c_str());
    const double d = (truth.poses[k].position_m - truth.poses[k - 1].position_m).head<2>().norm();
    CHECK(d >= 10.0 && d <= 12.0);
    DOUBLES_EQUAL(d, leg.distance_m, 1e-6);
    const Eigen::Vector3d delta = truth.poses[k - 1].toSite(truth.poses[k].position_m);
    for (int a = 0; a < 3; ++a) CHECK(std::fabs(leg.delta_m[a] - delta[a]) < 5.0 * leg.sigma_m[a]);
    CHECK(std::fabs(leg.delta_heading_rad - (truth.poses[k].heading_rad - truth.poses[k - 1].heading_rad)) <
          5.0 * leg.sigma_heading_rad);
    // The a-priori pose is the previous one moved by the odometry.
    const Eigen::Vector3d chained = t.sites[k - 1].apriori.toTraverse(leg.delta_m);
    CHECK((chained - t.sites[k].apriori.position_m).norm() < 1e-9);
  }
  // Some odometry error reached the last site.
  CHECK((t.sites.back().apriori.position_m - truth.poses.back().position_m).norm() > 1e-3);
}

TEST(TraverseSim, ACheckPointOfOneSiteMapsConsistentlyIntoThePreviousSite) {
  // From the files alone: a check point of site k (its frame) through the true poses lies on the terrain,
  // on site k-1's truth DEM in site k-1's frame, and where site k-1's true models see it, its image there
  // shows the same surface as site k's image at its true observation.
  const std::string& dir = tinyTraverseDir();
  const Terrain& terrain = tinyTraverseTerrain();
  const Traverse t = readTraverse(dir);
  const TraverseTruth truth = *readTraverseTruth(dir, t);
  std::vector<double> on_terrain, on_previous_dem, ncc_values, control_values;
  double worst_pixel = 0.0;
  for (std::size_t k = 1; k < t.sites.size(); ++k) {
    const SitePose& here = truth.poses[k];
    const SitePose& there = truth.poses[k - 1];
    const Dataset ds_here = readDataset(t.sites[k].dir), ds_there = readDataset(t.sites[k - 1].dir);
    const DemGrid dem_there = readDemGeoTiff(t.sites[k - 1].dir + "/" + kTruthDemFile);
    std::map<int64_t, const ImageObservation*> first_seen;
    const std::vector<ImageObservation> obs =
        readObservationsCsv(t.sites[k].dir + "/" + kTruthObservationsFile);
    for (const ImageObservation& o : obs) first_seen.emplace(o.point, &o);
    std::map<std::string, CameraModel> models_there;
    std::map<std::string, RenderedImage> images_there;
    for (const Pair& p : ds_there.pairs) {
      for (const ImageRef* side : {&p.left, &*p.right}) {
        models_there[side->stem] = io::readCameraModelFile(t.sites[k - 1].dir + "/" + kTruthModelsFolder +
                                                           "/" + side->stem + ".cahvor");
        images_there[side->stem] = loadRendered(side->image_path);
      }
    }
    std::map<std::string, RenderedImage> images_here;
    for (const Pair& p : ds_here.pairs) {
      for (const ImageRef* side : {&p.left, &*p.right})
        images_here[side->stem] = loadRendered(side->image_path);
    }
    for (const CheckPoint& cp : readPointsCsv(t.sites[k].dir + "/" + kTruthPointsFile)) {
      const Eigen::Vector3d on_traverse = here.toTraverse(cp.site_m);
      on_terrain.push_back(std::fabs(terrain.elevation(on_traverse.x(), on_traverse.y()) + on_traverse.z()));
      const Eigen::Vector3d p_there = there.toSite(on_traverse);
      const double e = demAt(dem_there, p_there.x(), p_there.y());
      if (std::isfinite(e)) on_previous_dem.push_back(std::fabs(e + p_there.z()));
      const ImageObservation& o = *first_seen.at(cp.point);
      const CameraModel model_in_site =
          io::readCameraModelFile(t.sites[k].dir + "/" + kTruthModelsFolder + "/" + o.image + ".cahvor");
      const CameraModel model_here = onTerrain(model_in_site, here);
      const CameraModel model_here_apriori = onTerrain(model_in_site, t.sites[k].apriori);
      for (const auto& [stem, model] : models_there) {
        Vec2 pixel, pixel_on_terrain;
        if (project(model, p_there, pixel) != Status::kOk) continue;
        const CameraModel model_on_terrain = onTerrain(model, there);
        if (!pointVisible(terrain, model_on_terrain, on_traverse, 4.0, pixel_on_terrain)) continue;
        worst_pixel = std::max(worst_pixel, (pixel - pixel_on_terrain).norm());
        double value = 0.0, control = 0.0;
        if (warpedNcc(terrain, model_on_terrain, images_there.at(stem), pixel, model_here,
                      images_here.at(o.image), 3, value) &&
            warpedNcc(terrain, model_on_terrain, images_there.at(stem), pixel, model_here_apriori,
                      images_here.at(o.image), 3, control)) {
          ncc_values.push_back(value);
          control_values.push_back(control);  // site k placed by its a-priori pose: other ground
        }
        break;  // one view from the previous site per point
      }
    }
  }
  printf(
      "\n%zu check points: |elevation - surface| on the terrain 95th pct %.2g m; on the previous site's "
      "truth "
      "DEM median %.2g m, 95th pct %.2g m (%zu inside it); %zu seen from the previous site, pixel difference "
      "site frame vs terrain frame %.2g px, 7x7 NCC with the point's own site median %.3f, 10th pct %.3f "
      "(site k placed by its a-priori pose instead: median %.3f)\n",
      on_terrain.size(), percentile(on_terrain, 0.95), percentile(on_previous_dem, 0.5),
      percentile(on_previous_dem, 0.95), on_previous_dem.size(), ncc_values.size(), worst_pixel,
      ncc_values.empty() ? 0.0 : percentile(ncc_values, 0.5),
      ncc_values.empty() ? 0.0 : percentile(ncc_values, 0.1),
      control_values.empty() ? 0.0 : percentile(control_values, 0.5));
  CHECK(percentile(on_terrain, 1.0) < 1e-4);
  CHECK(on_previous_dem.size() == on_terrain.size());
  CHECK(percentile(on_previous_dem, 0.5) < 0.005);
  CHECK(percentile(on_previous_dem, 0.95) < 0.03);
  CHECK(ncc_values.size() >= 20u);
  CHECK(worst_pixel < 1e-6);
  // 7x7 patches 10-25 m away on 256-pixel images: the surface's coarse texture only, but clearly the
  // same piece of ground, which the a-priori pose (off by the odometry error) misses.
  CHECK(percentile(ncc_values, 0.5) > 0.5);
  CHECK(percentile(control_values, 0.5) < 0.3);
}

TEST(TraverseSim, SameSeedSameFiles) {
  // The geometry and truth again without images (the images' bytes are the single-site renderer's, tested
  // in SimImages): every text file the same; another seed makes another traverse.
  const std::string& dir = tinyTraverseDir();
  const std::string again = test::scratchDir("traverse-sim-again") + "/traverse";
  TraverseSimOptions options;
  options.images = false;
  (void)writeTraverseDataset(tinyTraverse(), again, options);
  std::vector<std::string> files = {kTraverseFileName, kTraverseTruthFile};
  for (const char* site : {"site01", "site02", "site03"}) {
    for (const char* f : {"panorama.json", "truth/points.csv", "truth/observations.csv",
                          "models/p003_L.cahvor", "truth/models/p005_R.cahvor"}) {
      files.push_back(std::string("sites/") + site + "/" + f);
    }
  }
  for (const std::string& f : files) {
    const std::string a = readBytes(dir + "/" + f);
    CHECK_TEXT(!a.empty(), f.c_str());
    CHECK_TEXT(a == readBytes(again + "/" + f), f.c_str());
  }
  TraverseSimConfig other = tinyTraverse();
  other.seed = kSeed + 1;
  other.traverse.sites = 2;
  const std::string third = test::scratchDir("traverse-sim-other") + "/traverse";
  (void)writeTraverseDataset(other, third, options);
  CHECK(readBytes(dir + "/" + kTraverseFileName) != readBytes(third + "/" + kTraverseFileName));
}

TEST(TraverseSim, AStopLooksForwardOverAFewPairsOfEachTier) {
  for (const char* preset : {"navcam", "tiny", "fido", "imp"}) {
    const SimConfig site = presetConfig(preset);
    const SimConfig stop = stopConfig(site);
    int tiers = 0;
    for (const TierPlan& t : site.tiers) tiers += t.left_only ? 0 : 1;
    CHECK_EQUAL(tiers, static_cast<int>(stop.tiers.size()));
    for (const TierPlan& t : stop.tiers) {
      CHECK(!t.left_only);
      // Symmetric about the heading, the sector covered (fields included) and no pair more than needed.
      DOUBLES_EQUAL(0.0, t.pan0_deg + 0.5 * (t.pairs - 1) * t.pan_step_deg, 1e-9);
      const double covered = (t.pairs - 1) * t.pan_step_deg + site.hfov_deg;
      CHECK(covered >= kStopSectorDeg - 1e-9);
      CHECK(t.pairs == 1 || covered - t.pan_step_deg < kStopSectorDeg);
      CHECK(t.pairs < 360.0 / t.pan_step_deg);
    }
    validatePlan(stop);
  }
  CHECK_EQUAL(4, stopConfig(presetConfig("navcam")).pairCount());
}

TEST(TraverseSim, TheToolWritesATraverseAndRejectsBadOptions) {
  const std::string dir = test::scratchDir("traverse-sim-tool");
  CHECK_EQUAL(0, test::runTool("areomap-sim", "--preset traverse --camera tiny --sites 2 --no-images --out " +
                                                  dir + "/out"));
  const Traverse t = readTraverse(dir + "/out");
  CHECK_EQUAL(2, static_cast<int>(t.sites.size()));
  CHECK_EQUAL(
      2, test::runTool("areomap-sim", "--preset traverse --camera tiny --sites 0 --out " + dir + "/bad"));
  CHECK_EQUAL(
      2, test::runTool("areomap-sim", "--preset traverse --camera tiny --leg-min-m 30 --leg-max-m 10 --out " +
                                          dir + "/bad"));
  CHECK_EQUAL(2, test::runTool("areomap-sim", "--preset tiny --camera navcam --out " + dir + "/bad"));
  CHECK_EQUAL(2, test::runTool("areomap-sim", "--preset traverse --camera nosuch --out " + dir + "/bad"));
  CHECK(!test::fileExists(dir + "/bad/traverse.json"));
  // --help documents the traverse options.
  const std::string help = dir + "/help.txt";
  CHECK_EQUAL(0, std::system((test::toolPath("areomap-sim") + " --help > " + help).c_str()));
  const std::string text = readBytes(help);
  for (const char* option :
       {"--preset traverse", "--camera", "--sites", "--leg-min-m", "--leg-max-m", "--max-turn-deg",
        "--odometry-drift-pct", "--vertical-drift-pct", "--heading-drift-deg"}) {
    CHECK_TEXT(text.find(option) != std::string::npos, option);
  }
}
