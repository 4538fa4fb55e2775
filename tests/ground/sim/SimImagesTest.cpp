#include <sys/wait.h>

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
#include "ground/io/CameraFile.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/sim/Renderer.hpp"
#include "ground/sim/SimGeometry.hpp"
#include "ground/sim/SimWriter.hpp"
#include "ground/sim/Terrain.hpp"
#include "tests/ground/sim/ImagePatches.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using namespace areomap::sim;
using namespace areomap::sim::patches;

namespace {

struct TinyScene {
  SimConfig config = presetConfig("tiny");
  Terrain terrain = Terrain::build(config);
  SimGeometry geometry = makeGeometry(config, terrain);
  std::map<std::string, RenderedImage> images;
  TinyScene() {
    const std::vector<const SimCamera*> cams = geometry.cameras();
    for (std::size_t i = 0; i < cams.size(); ++i) {
      images[cams[i]->stem] = renderImage(terrain, config, cams[i]->truth, static_cast<int>(i));
    }
  }
};

const TinyScene& tinyScene() {
  static const TinyScene scene;
  return scene;
}

std::string readSimImageFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Runs build/bin/areomap-sim with arguments; returns the exit code, stderr in `err`.
int runSim(const std::string& args, std::string& err) {
  const std::string dir = test::scratchDir("sim-tool-stderr");  // <build>/test-scratch/sim-tool-stderr
  const std::string build = std::filesystem::path(dir).parent_path().parent_path().string();
  const std::string command = build + "/bin/areomap-sim " + args + " 2> " + dir + "/err.txt > /dev/null";
  const int status = std::system(command.c_str());
  err = readSimImageFile(dir + "/err.txt");
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

}  // namespace

TEST_GROUP(SimImages){};

TEST(SimImages, TrueProjectionsOfAPointMarkTheSameSurface) {
  const TinyScene& scene = tinyScene();
  std::map<int64_t, std::vector<const ImageObservation*>> by_point;
  // Observations reach the image edges; the windows here need 6 px of room.
  const double margin = 6.0;
  for (const ImageObservation& o : scene.geometry.observations) {
    if (o.sample_px >= margin && o.line_px >= margin && o.sample_px <= scene.config.width - 1 - margin &&
        o.line_px <= scene.config.height - 1 - margin) {
      by_point[o.point].push_back(&o);
    }
  }
  std::map<std::string, const CameraModel*> models;
  for (const SimCamera* c : scene.geometry.cameras()) models[c->stem] = &c->truth;
  std::vector<double> stereo, inter, warped;
  for (const auto& [point, obs] : by_point) {
    for (std::size_t i = 0; i < obs.size(); ++i) {
      for (std::size_t j = i + 1; j < obs.size(); ++j) {
        const Vec2 pi(obs[i]->sample_px, obs[i]->line_px), pj(obs[j]->sample_px, obs[j]->line_px);
        const RenderedImage& ii = scene.images.at(obs[i]->image);
        const RenderedImage& ij = scene.images.at(obs[j]->image);
        const double v = ncc(ii, pi, ij, pj, 5);
        (obs[i]->image.substr(0, 4) == obs[j]->image.substr(0, 4) ? stereo : inter).push_back(v);
        double w = 0.0;
        if (warpedNcc(scene.terrain, *models.at(obs[i]->image), ii, pi, *models.at(obs[j]->image), ij, 5,
                      w)) {
          warped.push_back(w);
        }
      }
    }
  }
  auto summary = [](std::vector<double> v, const char* what) {
    std::sort(v.begin(), v.end());
    const double above =
        static_cast<double>(std::count_if(v.begin(), v.end(), [](double x) { return x >= 0.9; })) / v.size();
    printf("%s: %zu patch pairs, NCC median %.3f, 10th percentile %.3f, %.1f %% >= 0.9\n", what, v.size(),
           v[v.size() / 2], v[v.size() / 10], 100.0 * above);
    return std::make_pair(v[v.size() / 2], above);
  };
  printf("\n11x11 patches around the true projections of %zu check points:\n", by_point.size());
  const auto [stereo_median, stereo_above] = summary(stereo, "plain windows, stereo (same pair)");
  const auto [inter_median, inter_above] = summary(inter, "plain windows, inter-stereo (other pairs)");
  const auto [warped_median, warped_above] =
      summary(warped, "same surface (B sampled where A's pixels land)");
  CHECK(stereo.size() >= 200u);
  CHECK(inter.size() >= 50u);
  CHECK(warped.size() >= 300u);
  CHECK(stereo_median >= 0.9);
  CHECK(warped_median >= 0.9);
  CHECK(warped_above >= 0.8);
  (void)inter_median;
  (void)inter_above;
  (void)stereo_above;
}

TEST(SimImages, ImagesHaveTextureAndSky) {
  const TinyScene& scene = tinyScene();
  for (const auto& [stem, im] : scene.images) {
    double mean = 0, var = 0;
    for (uint8_t p : im.pixels) mean += p;
    mean /= im.pixels.size();
    for (uint8_t p : im.pixels) var += (p - mean) * (p - mean);
    const double sd = std::sqrt(var / im.pixels.size());
    CHECK(mean > 40.0 && mean < 200.0);
    CHECK(sd > 8.0);
  }
}

TEST(SimImages, SameSeedSameBytesWhateverTheThreadCount) {
  SimConfig c = presetConfig("tiny");
  setPairCount(c, 2);
  c.width = 128;
  c.height = 96;
  c.half_extent_m = 12.0;
  c.check_points = 50;
  c.jpeg_quality = 90;
  const std::string a = test::scratchDir("sim-same-a"), b = test::scratchDir("sim-same-b"),
                    d = test::scratchDir("sim-same-c");
  c.threads = 1;
  writeSimDataset(makeGeometry(c), Terrain::build(c), a, WriteOptions{});
  c.threads = 3;
  writeSimDataset(makeGeometry(c), Terrain::build(c), b, WriteOptions{});
  c.seed = 2;
  writeSimDataset(makeGeometry(c), Terrain::build(c), d, WriteOptions{});
  int files = 0, differ_other_seed = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(a)) {
    if (!entry.is_regular_file()) continue;
    const std::string rel = std::filesystem::relative(entry.path(), a).string();
    const std::string bytes = readSimImageFile(entry.path().string());
    CHECK(!bytes.empty());
    if (bytes != readSimImageFile(b + "/" + rel)) FAIL(("differs between 1 and 3 threads: " + rel).c_str());
    if (rel.rfind("images/", 0) == 0 && bytes != readSimImageFile(d + "/" + rel)) ++differ_other_seed;
    ++files;
  }
  printf(
      "\n%d files byte-identical for the same seed (1 and 3 threads); %d images differ with another seed\n",
      files, differ_other_seed);
  CHECK_EQUAL(4, differ_other_seed);
  // The dataset reads back through the contract reader.
  const Dataset ds = readDataset(a);
  CHECK_EQUAL(2u, ds.pairs.size());
  checkDatasetFiles(ds, true, true);
  // The truth files read back: every true observation re-projects through its truth/models file.
  const std::vector<CheckPoint> points = readPointsCsv(a + "/" + kTruthPointsFile);
  const std::vector<ImageObservation> observations = readObservationsCsv(a + "/" + kTruthObservationsFile);
  CHECK(points.size() >= 20u);
  double worst = 0.0;
  for (const ImageObservation& o : observations) {
    const CameraModel m = io::readCameraModelFile(a + "/" + kTruthModelsFolder + "/" + o.image + ".cahvor");
    Vec2 px;
    CHECK(project(m, points[static_cast<std::size_t>(o.point)].site_m, px) == Status::kOk);
    worst = std::max(worst, (px - Vec2(o.sample_px, o.line_px)).norm());
  }
  printf("worst re-projection through the written truth models: %.2g px over %zu observations\n", worst,
         observations.size());
  CHECK(worst < 1e-6);
  CHECK(test::fileExists(a + "/truth/dem.tif"));
}

TEST(SimImages, ToolRejectsImpossiblePlansAndUnwritableFolders) {
  std::string err;
  const std::string out = test::scratchDir("sim-tool");
  CHECK_EQUAL(2, runSim("--preset tiny --pan-step-deg 80 --out " + out + "/x", err));
  printf("\n%s", err.c_str());
  CHECK(err.find("impossible plan: --pan-step-deg") != std::string::npos);
  CHECK_EQUAL(2, runSim("--preset tiny --tilts 40 --out " + out + "/x", err));
  CHECK(err.find("--tilts") != std::string::npos);
  CHECK_EQUAL(2, runSim("--preset mars --out " + out + "/x", err));
  CHECK_EQUAL(2, runSim("--preset tiny --pairs many --out " + out + "/x", err));
  CHECK_EQUAL(2, runSim("--preset tiny", err));
  std::ofstream(out + "/file") << "x";
  CHECK_EQUAL(
      1, runSim("--preset tiny --pairs 1 --no-images --check-points 10 --out " + out + "/file/sub", err));
  printf("%s", err.c_str());
  CHECK(err.find(out + "/file/sub") != std::string::npos);
  CHECK_EQUAL(0, runSim("--help", err));
  CHECK_EQUAL(
      0,
      runSim("--preset tiny --pairs 2 --size 96 64 --no-images --check-points 20 --out " + out + "/ok", err));
  CHECK(test::fileExists(out + "/ok/panorama.json"));
  CHECK(test::fileExists(out + "/ok/truth/observations.csv"));
  CHECK_FALSE(test::fileExists(out + "/ok/images"));
  // Overrides combine: two tiers by --tilts, four pairs by --pairs (two per tier).
  CHECK_EQUAL(
      0, runSim("--preset tiny --tilts=-30,-50 --pairs 4 --size 96 64 --no-images --check-points 20 --out " +
                    out + "/tiers",
                err));
  const Dataset ds = readDataset(out + "/tiers");
  CHECK_EQUAL(4u, ds.pairs.size());
  CHECK_EQUAL(0, ds.pairs[1].tier);
  CHECK_EQUAL(1, ds.pairs[2].tier);
  CHECK_EQUAL(96, ds.width);
}
