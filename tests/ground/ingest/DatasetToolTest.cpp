// areomap-dataset end to end: the shared folder of real pairs (5 pairs -> 4 datasets, sol 395 two
// pointings in one), every result read by readDataset and its models by areomap-camera; a mixed folder
// (real records, a lone eye, MER frames without partners, VICAR pairs written by GDAL -- one in the rover
// navigation frame, one in a frame the label does not place -- a corrupt record and a record without its
// image): exit 1, the good datasets written, every other input in index.json with its reason.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <Eigen/Geometry>

#include "ground/dataset/Dataset.hpp"
#include "ground/ingest/SiteFrame.hpp"
#include "ground/io/CameraFile.hpp"
#include "tests/firmware_core/camera/TestModels.hpp"
#include "tests/ground/io/GdalTestFiles.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

json readJson(const std::string& path) {
  std::ifstream f(path);
  return json::parse(f);
}

// The reasons in index.json's skipped list, by input file name.
std::map<std::string, std::string> skippedByName(const json& index) {
  std::map<std::string, std::string> out;
  for (const json& s : index["skipped"])
    out[fs::path(s["input"].get<std::string>()).filename().string()] = s["reason"];
  return out;
}

// Checks one written dataset: readDataset accepts it, each model reads with areomap-camera, each pair's
// centres 0.4244 m apart (the Navcam base, for M2020 Navcam pairs), each image 8-bit grey of the model's
// size.
void checkDataset(const std::string& folder, double base_m) {
  const Dataset d = readDataset(folder);
  for (const Pair& p : d.pairs) {
    CHECK(p.right.has_value());
    const CameraModel l = io::readCameraModelFile(p.left.model_path);
    const CameraModel r = io::readCameraModelFile(p.right->model_path);
    if (base_m > 0.0) DOUBLES_EQUAL(base_m, (r.c - l.c).norm(), 0.0005);
    for (const ImageRef* ref : {&p.left, &*p.right}) {
      const cv::Mat img = cv::imread(ref->image_path, cv::IMREAD_UNCHANGED);
      CHECK_EQUAL(CV_8UC1, img.type());
      CHECK_EQUAL(l.width, img.cols);
      CHECK_EQUAL(0, test::runTool("areomap-camera", "'" + ref->model_path + "' --json"));
    }
  }
}

}  // namespace

TEST_GROUP(DatasetTool){};

TEST(DatasetTool, UsageAndHelp) {
  CHECK_EQUAL(0, test::runTool("areomap-dataset", "--help"));
  CHECK_EQUAL(2, test::runTool("areomap-dataset", "--out /tmp/x"));
  CHECK_EQUAL(2, test::runTool("areomap-dataset", "somewhere"));
}

TEST(DatasetTool, SharedPairsFolder) {
  if (!test::requireSharedData("m2020-navcam-stereo-pairs")) return;
  const std::string input = test::sharedDataDir() + "/m2020-navcam-stereo-pairs";
  const std::string out = test::scratchDir("dataset-shared");
  CHECK_EQUAL(0, test::runTool("areomap-dataset", "'" + input + "' --out '" + out + "'"));
  const json index = readJson(out + "/index.json");
  CHECK_EQUAL(4, static_cast<int>(index["datasets"].size()));
  std::set<std::string> names;
  for (const json& d : index["datasets"]) {
    names.insert(d["name"].get<std::string>());
    const json panorama = readJson(out + "/" + d["folder"].get<std::string>() + "/panorama.json");
    CHECK_EQUAL(d["pairs"].size(), panorama["pairs"].size());
    for (const json& p : panorama["pairs"]) {
      const std::string left = p["left"]["source"], right = p["right"]["source"];
      CHECK(left.rfind(input + "/NLF_", 0) == 0);
      CHECK(right.rfind(input + "/NRF_", 0) == 0);
      CHECK_EQUAL(
          0, left.compare(input.size() + 4, std::string::npos, right, input.size() + 4, std::string::npos));
    }
    checkDataset(out + "/" + d["folder"].get<std::string>(), 0.4244);
  }
  const std::set<std::string> expected = {
      "m2020_sol0340_site009_drive0364", "m2020_sol0380_site011_drive2472", "m2020_sol0395_site017_drive1064",
      "m2020_sol1280_site060_drive0186"};
  CHECK(names == expected);
  const Dataset sol395 = readDataset(out + "/m2020_sol0395_site017_drive1064");
  CHECK_EQUAL(2, static_cast<int>(sol395.pairs.size()));
  CHECK_EQUAL(395, sol395.pairs[1].sol);
  CHECK_EQUAL(0, sol395.pairs[1].tier);  // both pointings at about -33 deg
  const auto skipped = skippedByName(index);
  CHECK_EQUAL(1, static_cast<int>(skipped.size()));
  CHECK(skipped.count("PROVENANCE.txt") == 1);
}

TEST(DatasetTool, MixedFolderWithBadFiles) {
  const bool real = test::requireSharedData("m2020-navcam-stereo-pairs") &&
                    test::requireSharedData("mer-opportunity-navcam-sol4087");
  const std::string in = test::scratchDir("dataset-mixed-in");
  const std::string out = test::scratchDir("dataset-mixed-out");
  // VICAR pairs written by GDAL: one in the rover navigation frame (-> a dataset at site 5, drive 10), one
  // in a frame the label gives no pose for.
  const CameraModel left = test::m2020Like(CahvoreKind::kFisheye, 0.0);
  CameraModel right = left;
  right.c += 0.4244 * Vec3(0.0, 1.0, 0.0);
  const cv::Mat img = test::rampImage(left.width, left.height, CV_16U, 4000.0);
  const std::string tail = "_0100_0690000000_000ECM_N0050010NCAM00001_01_095J01";
  fs::create_directories(in + "/vicar");
  test::writeWithGdal(in + "/vicar/NLF" + tail + ".VIC", "VICAR", img, "json:VICAR",
                      test::vicarLabel(left, "NAVCAM_LEFT", "NLF" + tail, "ROVER_NAV_FRAME", 5, 10).dump());
  test::writeWithGdal(in + "/vicar/NRF" + tail + ".VIC", "VICAR", img, "json:VICAR",
                      test::vicarLabel(right, "NAVCAM_RIGHT", "NRF" + tail, "ROVER_NAV_FRAME", 5, 10).dump());
  // A second pointing at the same position, 30 deg lower: the next tier.
  // (Turning A about A x down moves it towards +Z, down.)
  const Mat3 pitch =
      Eigen::AngleAxisd(30.0 * M_PI / 180.0, left.a.cross(Vec3::UnitZ()).normalized()).toRotationMatrix();
  CHECK(std::asin(-(pitch * left.a).z()) < std::asin(-left.a.z()) - 25.0 * M_PI / 180.0);
  const std::string low = "_0100_0690000100_000ECM_N0050010NCAM00001_01_095J01";
  test::writeWithGdal(in + "/vicar/NLF" + low + ".VIC", "VICAR", img, "json:VICAR",
                      test::vicarLabel(ingest::transformedModel(left, pitch, Vec3::Zero()), "NAVCAM_LEFT",
                                       "NLF" + low, "ROVER_NAV_FRAME", 5, 10)
                          .dump());
  test::writeWithGdal(in + "/vicar/NRF" + low + ".VIC", "VICAR", img, "json:VICAR",
                      test::vicarLabel(ingest::transformedModel(right, pitch, Vec3::Zero()), "NAVCAM_RIGHT",
                                       "NRF" + low, "ROVER_NAV_FRAME", 5, 10)
                          .dump());
  const std::string mech = "_0101_0690100000_000ECM_N0050010NCAM00001_01_095J01";
  test::writeWithGdal(in + "/vicar/NLF" + mech + ".VIC", "VICAR", img, "json:VICAR",
                      test::vicarLabel(left, "NAVCAM_LEFT", "NLF" + mech, "ROVER_MECH_FRAME", 5, 11).dump());
  test::writeWithGdal(
      in + "/vicar/NRF" + mech + ".VIC", "VICAR", img, "json:VICAR",
      test::vicarLabel(right, "NAVCAM_RIGHT", "NRF" + mech, "ROVER_MECH_FRAME", 5, 11).dump());
  // A corrupt record and a record whose image is missing.
  std::ofstream(in + "/NLF_0999_0799999999_000ECM_N0999999NCAM00001_01_095J.json")
      << "{\"camera\": {\"camera_model_";
  if (real) {
    const std::string pairs = test::sharedDataDir() + "/m2020-navcam-stereo-pairs/";
    for (const char* f : {"NLF_0340_0697121914_417ECM_N0090364NCAM00420_01_195J",
                          "NRF_0340_0697121914_417ECM_N0090364NCAM00420_01_195J",
                          "NLF_0380_0700686262_301ECM_N0112472NCAM03380_01_195J"}) {
      fs::copy_file(pairs + f + ".json", in + "/" + f + ".json");
      fs::copy_file(pairs + f + ".png", in + "/" + f + ".png");
    }
    // The sol-395 position: one good pair, one whose left image is truncated (its header intact).
    for (const char* f : {"NLF_0395_0702014201_058ECM_N0171064NCAM03395_01_195J",
                          "NRF_0395_0702014201_058ECM_N0171064NCAM03395_01_195J",
                          "NLF_0395_0702014384_287ECM_N0171064NCAM03395_01_195J",
                          "NRF_0395_0702014384_287ECM_N0171064NCAM03395_01_195J"}) {
      fs::copy_file(pairs + f + ".json", in + "/" + f + ".json");
      fs::copy_file(pairs + f + ".png", in + "/" + f + ".png");
    }
    fs::resize_file(in + "/NLF_0395_0702014384_287ECM_N0171064NCAM03395_01_195J.png", 4000);
    fs::copy_file(pairs + "NRF_0380_0700686262_301ECM_N0112472NCAM03380_01_195J.json",
                  in + "/NRF_0380_0700686262_301ECM_N0112472NCAM03380_01_195J.json");  // no image
    fs::copy_file(test::sharedDataDir() + "/mer-opportunity-navcam-sol4087/1N491020376ILFCNY9P0706L0M1.IMG",
                  in + "/1N491020376ILFCNY9P0706L0M1.IMG");
  }
  CHECK_EQUAL(1, test::runTool("areomap-dataset", "'" + in + "' --out '" + out + "'"));
  const json index = readJson(out + "/index.json");
  std::set<std::string> names;
  for (const json& d : index["datasets"]) names.insert(d["name"].get<std::string>());
  CHECK(names.count("m2020_sol0395_site005_drive0010") == 1);
  checkDataset(out + "/m2020_sol0395_site005_drive0010", 0.0);
  const Dataset vicar = readDataset(out + "/m2020_sol0395_site005_drive0010");
  CHECK_EQUAL(2, static_cast<int>(vicar.pairs.size()));
  CHECK_EQUAL(0, vicar.pairs[0].tier);  // the same clock: in source order, the level pair first
  CHECK_EQUAL(1, vicar.pairs[1].tier);
  // 12-bit data in 16-bit words -> x 255 / 4095.
  const cv::Mat grey = cv::imread(vicar.pairs[0].left.image_path, cv::IMREAD_UNCHANGED);
  DOUBLES_EQUAL(std::round(img.at<uint16_t>(5, 7) * 255.0 / 4095.0), grey.at<uint8_t>(5, 7), 0.0);
  const auto skipped = skippedByName(index);
  const auto reason = [&](const std::string& name) {
    return skipped.count(name) ? skipped.at(name) : std::string();
  };
  CHECK(reason("NLF" + mech + ".VIC").find("ROVER_MECH_FRAME") != std::string::npos);
  CHECK(reason("NLF_0999_0799999999_000ECM_N0999999NCAM00001_01_095J.json").find("json") !=
        std::string::npos);
  if (real) {
    CHECK(names.count("m2020_sol0340_site009_drive0364") == 1);
    CHECK_EQUAL(3, static_cast<int>(names.size()));
    const Dataset sol395 = readDataset(out + "/m2020_sol0395_site017_drive1064");
    CHECK_EQUAL(1, static_cast<int>(sol395.pairs.size()));
    CHECK(reason("NLF_0395_0702014384_287ECM_N0171064NCAM03395_01_195J.json").find("image") !=
          std::string::npos);
    CHECK(reason("NRF_0395_0702014384_287ECM_N0171064NCAM03395_01_195J.json").find("its partner's image") ==
          0);
    CHECK(reason("NLF_0380_0700686262_301ECM_N0112472NCAM03380_01_195J.json")
              .find("an eye without its partner") == 0);
    CHECK(reason("NRF_0380_0700686262_301ECM_N0112472NCAM03380_01_195J.json").find("no image beside") !=
          std::string::npos);
    CHECK(reason("1N491020376ILFCNY9P0706L0M1.IMG").find("an eye without its partner") == 0);
  }
  for (const auto& [name, why] : skipped) std::printf("\n  skipped %s: %s", name.c_str(), why.c_str());
  std::printf("\n");
}
