// The ground pass on every real Perseverance Navcam pair of ../shared/data/m2020-navcam-stereo-pairs (tiles
// of 1288 x 968 with the principal point at their corner, a 1280 x 960 full frame, a fisheye-linearity
// CAHVORE model per eye, one position with two pointings that do not overlap, the others one pair alone).
// No truth exists, so the pass is checked by evidence it never used: SIFT matches of the original images,
// triangulated through the a-priori and through the written (adjusted or kept) models. Each line printed
// is the measurement: ties, rejected, method 1 before/after, the independent matches' reprojection RMS
// through both model sets, and the DEM's coverage of what both cameras see at 2-5 and 5-10 m.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/DemRaster.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/node/GroundPass.hpp"
#include "ground/pass/PassProducts.hpp"
#include "tests/ground/pass/PassChecks.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

constexpr const char* kFolder = "m2020-navcam-stereo-pairs";

struct PairFigures {
  std::string stem;
  test::ModelComparison sift;
  double cover_2_5 = -1.0, cover_5_10 = -1.0;
  bool adjusted = false;
};

struct PositionRun {
  std::string name;
  nlohmann::json report;
  std::vector<PairFigures> pairs;
};

// The pass (with products) on every position, once per process.
const std::vector<PositionRun>& runs() {
  static const std::vector<PositionRun> all = [] {
    std::vector<PositionRun> out;
    const std::string scratch = test::scratchDir("real-pairs");
    for (const std::string& dir :
         test::writeRecordDatasets(test::sharedDataDir() + "/" + kFolder, scratch + "/datasets")) {
      const Dataset dataset = readDataset(dir);
      ground::GroundPassOptions options;
      options.out_dir = scratch + "/out/" + dataset.name;
      options.progress = false;
      options.products_hook = ground::makePassProducts;
      (void)ground::runGroundPass(dataset, options, nullptr, nullptr);
      PositionRun run;
      run.name = dataset.name;
      run.report = nlohmann::json::parse(std::ifstream(options.out_dir + "/report.json"));
      const DemGrid dem = readDemGeoTiff(options.out_dir + "/dem.tif");
      for (std::size_t k = 0; k < dataset.pairs.size(); ++k) {
        const Pair& pair = dataset.pairs[k];
        const ImageRef& l = pair.left;
        const ImageRef& r = *pair.right;
        const CameraModel al = io::readCameraModelFile(l.model_path),
                          ar = io::readCameraModelFile(r.model_path);
        const CameraModel bl = io::readCameraModelFile(options.out_dir + "/models/" + l.stem + ".cahvor");
        const CameraModel br = io::readCameraModelFile(options.out_dir + "/models/" + r.stem + ".cahvor");
        PairFigures f;
        f.stem = l.stem;
        const test::FeatureMatches m = test::siftMatches(cv::imread(l.image_path, cv::IMREAD_GRAYSCALE),
                                                         cv::imread(r.image_path, cv::IMREAD_GRAYSCALE));
        f.sift = test::compareModels(m, al, ar, bl, br);
        f.cover_2_5 = test::demCoverage(dem, bl, br, 2.0, 5.0);
        f.cover_5_10 = test::demCoverage(dem, bl, br, 5.0, 10.0);
        f.adjusted = run.report["adjustment_check"]["pairs"][k]["adjusted"].get<bool>();
        run.pairs.push_back(f);
      }
      out.push_back(run);
    }
    return out;
  }();
  return all;
}

}  // namespace

TEST_GROUP(RealPairs){};

// Every position maps; the figures are printed (the measurement) and the written models explain
// independent SIFT matches no worse than the a-priori models do.
TEST(RealPairs, AdjustedModelsNoWorseOnIndependentMatches) {
  if (!test::requireSharedData(kFolder)) return;
  const std::vector<PositionRun>& all = runs();
  CHECK(all.size() >= 4);
  for (const PositionRun& run : all) {
    const nlohmann::json& j = run.report;
    for (const PairFigures& f : run.pairs) {
      std::printf(
          "\n%-17s %s: tie points %d, rejected observations %d, method 1 %.3f -> %.3f px, %s; SIFT %d "
          "matches: "
          "a-priori %.3f px, written %.3f px; DEM coverage 2-5 m %.0f %%, 5-10 m %.0f %%",
          run.name.c_str(), f.stem.substr(0, 28).c_str(), j["tie_points"]["intra"].get<int>(),
          j["tie_points"]["rejected"].get<int>(), j["method1_px"]["before"]["dist"].get<double>(),
          j["method1_px"]["after"]["dist"].get<double>(), f.adjusted ? "adjusted" : "a-priori kept",
          f.sift.matches, f.sift.rms_a_px, f.sift.rms_b_px, 100.0 * f.cover_2_5, 100.0 * f.cover_5_10);
      CHECK(f.sift.matches >= 50);
      // No worse than the a-priori models: within 5 % (SIFT's own localisation noise moves the figure a
      // little between two nearly equal model sets).
      CHECK(f.sift.rms_b_px <= 1.05 * f.sift.rms_a_px);
    }
    // The ties' residual after the adjustment stays at the matching noise (method 1, mean distance).
    CHECK(j["method1_px"]["after"]["dist"].get<double>() <= 0.3);
  }
  std::printf("\n");
}

// Rectification of every real pair keeps what the original images show: each original left pixel whose
// ray at 10 m meets the right image (the overlap) lands inside the rectified left image, and the rectified
// image holds at most twice the original's pixels (no blow-up).
TEST(RealPairs, RectificationKeepsTheOverlap) {
  if (!test::requireSharedData(kFolder)) return;
  const std::string scratch = test::scratchDir("real-pairs-rect");
  for (const std::string& dir :
       test::writeRecordDatasets(test::sharedDataDir() + "/" + kFolder, scratch + "/datasets")) {
    const Dataset dataset = readDataset(dir);
    for (const Pair& pair : dataset.pairs) {
      const CameraModel l = io::readCameraModelFile(pair.left.model_path);
      const CameraModel r = io::readCameraModelFile(pair.right->model_path);
      const test::RectificationCover c = test::rectificationCover(l, r, 10.0);
      std::printf("\n%s: rectified %dx%d, overlap pixels %d, inside the rectified left image %.1f %%",
                  pair.left.stem.substr(0, 28).c_str(), c.width, c.height, c.overlap, 100.0 * c.inside);
      CHECK(static_cast<double>(c.width) * c.height <= 2.0 * l.width * l.height);
      CHECK(c.inside >= 0.99);
    }
  }
  std::printf("\n");
}
