// The Mars 2020 raw-image record as served (nested "camera" / "extended", tuples and numbers written as
// strings) and the pixel frame of its model when the instrument's detector is known (PixelFrame.hpp,
// Detector.hpp): the five real pairs of ../shared/data (skipped when absent), the flattened form of the
// same records, and synthetic Navcam tiles from every quarter of the 5120 x 3840 detector over several
// seeds, each read model checked against the truth by projection.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "firmware_core/camera/CahvInternal.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/io/PixelFrame.hpp"
#include "tests/firmware_core/camera/TestModels.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using nlohmann::json;

namespace {

const char* const kPairs = "m2020-navcam-stereo-pairs";

std::string pairsDir() {
  return test::sharedDataDir() + "/" + kPairs;
}

std::vector<std::string> servedRecords() {
  std::vector<std::string> out;
  for (const char* eye : {"NLF", "NRF"}) {
    for (const char* tail : {"_0340_0697121914_417ECM_N0090364NCAM00420_01_195J",
                             "_0380_0700686262_301ECM_N0112472NCAM03380_01_195J",
                             "_0395_0702014201_058ECM_N0171064NCAM03395_01_195J",
                             "_0395_0702014384_287ECM_N0171064NCAM03395_01_195J",
                             "_1280_0780577966_409ECM_N0600186NCAM00301_01_295J"}) {
      out.push_back(pairsDir() + "/" + eye + tail + ".json");
    }
  }
  return out;
}

json readJson(const std::string& path) {
  std::ifstream f(path);
  return json::parse(f);
}

std::vector<double> numbers(const std::string& tuple) {
  std::vector<double> out;
  std::string s = tuple;
  for (char& c : s) {
    if (c == '(' || c == ')' || c == ',') c = ' ';
  }
  std::istringstream in(s);
  double x = 0.0;
  while (in >> x) out.push_back(x);
  return out;
}

std::string recordTuple(const Vec3& v) {
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, "(%.17g,%.17g,%.17g)", v.x(), v.y(), v.z());
  return buffer;
}

std::string componentList(const CameraModel& m) {
  return recordTuple(m.c) + ";" + recordTuple(m.a) + ";" + recordTuple(m.h) + ";" + recordTuple(m.v) + ";" +
         recordTuple(m.o) + ";" + recordTuple(m.r) + ";" + recordTuple(m.e) + ";" +
         std::to_string(static_cast<int>(m.cahvore_kind)) + ".0;" + std::to_string(m.linearity);
}

// A served record of `m` (written as given) for a w x h image cut at 1-based (x0, y0) at scale s.
json servedRecord(const CameraModel& m, const char* instrument, int w, int h, int s, int x0, int y0) {
  return json{{"camera",
               {{"camera_model_component_list", componentList(m)},
                {"instrument", instrument},
                {"camera_model_type", "CAHVORE"}}},
              {"extended",
               {{"scaleFactor", std::to_string(s)},
                {"subframeRect", "(" + std::to_string(x0) + "," + std::to_string(y0) + "," +
                                     std::to_string(s * w) + "," + std::to_string(s * h) + ")"},
                {"dimension", "(" + std::to_string(w) + "," + std::to_string(h) + ")"},
                {"sclk", "702014201.641"},
                {"xyz", "(1,2,3)"}}},
              {"sol", 395},
              {"site", 17},
              {"drive", "1064"},
              {"attitude", "(1,0,0,0)"},
              {"imageid", "NLF_0395_0702014201_058ECM_N0171064NCAM03395_01_195J"}};
}

std::string writeRecordFile(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// The largest pixel distance between `read` and `truth` over a 7 x 7 grid of the image at 2 and 50 m.
double recordDisagreementPx(const CameraModel& read, const CameraModel& truth) {
  double worst = 0.0;
  for (int j = 0; j < 7; ++j) {
    for (int i = 0; i < 7; ++i) {
      const Vec2 pixel(-0.5 + truth.width * (i + 0.5) / 7.0, -0.5 + truth.height * (j + 0.5) / 7.0);
      Vec3 origin, dir;
      if (unproject(truth, pixel, origin, dir) != Status::kOk) return INFINITY;
      for (double range : {2.0, 50.0}) {
        Vec2 a;
        if (project(read, origin + range * dir, a) != Status::kOk) return INFINITY;
        worst = std::fmax(worst, (a - pixel).norm());
      }
    }
  }
  return worst;
}

}  // namespace

TEST_GROUP(M2020Record){};

// Every served record reads: the model is the record's own components in the delivered image's pixels
// (no rescaling: the tiles' principal point at their lower-right corner, the full frame's near its
// centre), the frame ROVER_NAV_FRAME (not stated by the record), and the acquisition as the record says.
TEST(M2020Record, ServedRecordsAsGiven) {
  if (!test::requireSharedData(kPairs)) return;
  for (const std::string& path : servedRecords()) {
    const json j = readJson(path);
    const io::CameraFile f = io::readCameraFile(path);
    const std::string list = j["camera"]["camera_model_component_list"].get<std::string>();
    const std::vector<double> h = numbers(list.substr(list.find(';', list.find(';') + 1) + 1));
    const std::vector<double> dim = numbers(j["extended"]["dimension"].get<std::string>());
    CHECK_EQUAL(static_cast<int>(dim[0]), f.model.width);
    CHECK_EQUAL(static_cast<int>(dim[1]), f.model.height);
    DOUBLES_EQUAL(h[0], f.model.h.x(), 1e-9);
    STRCMP_EQUAL("as given", f.frame.c_str());
    STRCMP_EQUAL("ROVER_NAV_FRAME", f.reference_frame.c_str());
    CHECK_FALSE(f.reference_frame_stated);
    const io::Acquisition& a = f.acquisition;
    CHECK(a.mission == io::Mission::kM2020);
    STRCMP_EQUAL(j["imageid"].get<std::string>().c_str(), a.product_id.c_str());
    STRCMP_EQUAL(j["camera"]["instrument"].get<std::string>().c_str(), a.instrument.c_str());
    CHECK_EQUAL(j["sol"].get<int>(), *a.sol);
    CHECK_EQUAL(j["site"].get<int>(), *a.site);
    CHECK_EQUAL(std::stoi(j["drive"].get<std::string>()), *a.drive);
    DOUBLES_EQUAL(std::stod(j["extended"]["sclk"].get<std::string>()), *a.sclk_s, 1e-6);
    const std::vector<double> q = numbers(j["attitude"].get<std::string>());
    const std::vector<double> xyz = numbers(j["extended"]["xyz"].get<std::string>());
    for (int k = 0; k < 4; ++k) DOUBLES_EQUAL(q[static_cast<std::size_t>(k)], (*a.attitude)(k), 1e-5);
    for (int k = 0; k < 3; ++k) DOUBLES_EQUAL(xyz[static_cast<std::size_t>(k)], (*a.xyz_m)(k), 1e-9);
    DOUBLES_EQUAL(std::stod(j["extended"]["mastAz"].get<std::string>()), *a.mast_az_deg, 1e-9);
    const CahvInternal in = cahvInternal(f.model);
    std::printf("\n  %s: pp (%.1f, %.1f) in %dx%d", a.product_id.c_str(), in.hc_px, in.vc_px, f.model.width,
                f.model.height);
    if (f.model.width == 1288) CHECK(in.hc_px > f.model.width && in.vc_px > f.model.height);
    if (f.model.width == 1280)
      CHECK(std::fabs(in.hc_px - 640.0) < 20.0 && std::fabs(in.vc_px - 480.0) < 20.0);
    CHECK_EQUAL(0, test::runTool("areomap-camera", "'" + path + "' --json"));
  }
  std::printf("\n");
}

// The rule without the detector reads these tiles as full-resolution pixels of a 2576 x 1936 detector at
// the metadata's scale (principal point at the image centre): what the known detector corrects.
TEST(M2020Record, WithoutTheDetectorATileIsMisread) {
  if (!test::requireSharedData(kPairs)) return;
  const io::CameraFile f = io::readCameraFile(servedRecords()[2]);
  const CahvInternal in = cahvInternal(f.file_model);
  io::FrameEvidence e;
  e.principal_px = Vec2(in.hc_px, in.vc_px);
  e.width = 1288;
  e.height = 968;
  e.meta_scale = 2;
  io::PixelFrame without, with;
  std::string tried;
  CHECK(io::choosePixelFrame(e, without, tried));
  DOUBLES_EQUAL(2.0, without.scale, 0.0);
  e.detector_px = Vec2(5120, 3840);
  CHECK(io::choosePixelFrame(e, with, tried));
  DOUBLES_EQUAL(1.0, with.scale, 0.0);
  STRCMP_EQUAL("as given", with.name.c_str());
}

// The flattened form of the same record reads to the same model, frame and acquisition; the flattened
// m2020-navcam-cahvore record (model in detector pixels, metadata saying scale 1) still reads as 1/4.
TEST(M2020Record, FlattenedFormsAsBefore) {
  if (!test::requireSharedData(kPairs) || !test::requireSharedData("m2020-navcam-cahvore")) return;
  const std::string dir = test::scratchDir("m2020-flattened");
  for (const std::string& path : servedRecords()) {
    json j = readJson(path);
    json flat = j;
    for (const auto& item : j["camera"].items()) flat[item.key()] = item.value();
    flat["subframe_rect"] = numbers(j["extended"]["subframeRect"].get<std::string>());
    flat["scale_factor"] = std::stod(j["extended"]["scaleFactor"].get<std::string>());
    flat["dimension"] = j["extended"]["dimension"];
    flat["xyz"] = j["extended"]["xyz"];
    flat["sclk"] = std::stod(j["extended"]["sclk"].get<std::string>());
    flat.erase("camera");
    flat.erase("extended");
    const io::CameraFile served = io::readCameraFile(path);
    const io::CameraFile f = io::readCameraFile(writeRecordFile(dir + "/flat.json", flat.dump()));
    CHECK((f.model.h - served.model.h).norm() < 1e-9 && (f.model.c - served.model.c).norm() < 1e-12);
    STRCMP_EQUAL(served.frame.c_str(), f.frame.c_str());
    CHECK_EQUAL(*served.acquisition.drive, *f.acquisition.drive);
    DOUBLES_EQUAL(*served.acquisition.sclk_s, *f.acquisition.sclk_s, 1e-6);
  }
  const io::CameraFile old = io::readCameraFile(
      test::sharedDataDir() +
      "/m2020-navcam-cahvore/NLF_0670_0726421423_362ECM_N0320604NCAM08111_01_095J01-metadata.json");
  STRCMP_EQUAL("1/4 of the detector from (1, 1)", old.frame.c_str());
  DOUBLES_EQUAL(4.0, old.scale, 0.0);
  DOUBLES_EQUAL(1.5, old.offset_px.x(), 0.0);
}

// A real tile moved to the other half of the sensor (subframe from sample 2545, its model shifted by the
// 1272 delivered pixels): principal point near the LEFT edge, read as given, projecting 1272 px left of the
// original.
TEST(M2020Record, TileFromTheOtherHalf) {
  if (!test::requireSharedData(kPairs)) return;
  const std::string path = servedRecords()[7];  // NRF sol 395
  const io::CameraFile original = io::readCameraFile(path);
  json j = readJson(path);
  CameraModel shifted = original.model;
  shifted.h = original.model.h - 1272.0 * original.model.a;
  j["camera"]["camera_model_component_list"] = componentList(shifted);
  j["extended"]["subframeRect"] = "(2545,1,2576,1936)";
  const std::string dir = test::scratchDir("m2020-other-half");
  const io::CameraFile f = io::readCameraFile(writeRecordFile(dir + "/NRF_tile.json", j.dump()));
  STRCMP_EQUAL("as given", f.frame.c_str());
  const CahvInternal in = cahvInternal(f.model);
  CHECK(in.hc_px > 0.0 && in.hc_px < 50.0);
  for (double range : {2.0, 20.0}) {
    Vec3 origin, dir_v;
    CHECK(unproject(original.model, Vec2(1287.0, 967.0), origin, dir_v) == Status::kOk);
    Vec2 a, b;
    CHECK(project(original.model, origin + range * dir_v, a) == Status::kOk);
    CHECK(project(f.model, origin + range * dir_v, b) == Status::kOk);
    DOUBLES_EQUAL(a.x() - 1272.0, b.x(), 1e-6);
    DOUBLES_EQUAL(a.y(), b.y(), 1e-6);
  }
}

// Synthetic Navcam models (5120 x 3840 detector, principal point within 1.5 % of its centre, random
// pointing) over seeds, served in every kind of frame the service uses: quarter tiles at 1/2 from each
// corner with the model in the tile's pixels, the full frame at 1/4 in its pixels, the full frame at 1/4
// with the model in detector pixels. Each read model projects as the truth (< 1e-6 px).
TEST(M2020Record, SyntheticNavcamFramesOverSeeds) {
  const std::string dir = test::scratchDir("m2020-synthetic");
  for (int seed = 1; seed <= 6; ++seed) {
    std::mt19937 rng(static_cast<unsigned>(seed));
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const double f = 2950.0 * (1.0 + 0.02 * u(rng));
    test::ModelSpec spec{f,
                         f * (1.0 + 0.001 * u(rng)),
                         2559.5 + 0.015 * 5120 * u(rng),
                         1919.5 + 0.015 * 3840 * u(rng),
                         0.0005,
                         M_PI * u(rng),
                         0.8 * u(rng),
                         M_PI * u(rng),
                         0.1 * M_PI / 180.0,
                         Vec3(1.7e-6, 0.05, -0.017),
                         5120,
                         3840};
    CameraModel detector = test::modelFromSpec(spec, Vec3(u(rng), u(rng), -1.9));
    detector.type = CameraType::kCahvore;
    detector.cahvore_kind = CahvoreKind::kFisheye;
    detector.linearity = 0.0;
    detector.e = Vec3(-8e-9, 1e-8, -2.9e-8);
    struct Case {
      int s, ox, oy, w, h;
      bool written_in_detector;
    };
    const Case cases[] = {{2, 0, 0, 1288, 968, false},    {2, 2544, 0, 1288, 968, false},
                          {2, 0, 1904, 1288, 968, false}, {2, 2544, 1904, 1288, 968, false},
                          {4, 0, 0, 1280, 960, false},    {4, 0, 0, 1280, 960, true}};
    for (const Case& c : cases) {
      const CameraModel truth =
          io::rescaledModel(detector, c.s, Vec2(c.ox, c.oy) + Vec2::Constant(0.5 * (c.s - 1)), c.w, c.h);
      const CameraModel& written = c.written_in_detector ? detector : truth;
      const json record =
          servedRecord(written, seed % 2 ? "NAVCAM_LEFT" : "NAVCAM_RIGHT", c.w, c.h, c.s, c.ox + 1, c.oy + 1);
      const io::CameraFile read = io::readCameraFile(writeRecordFile(dir + "/record.json", record.dump()));
      const double px = recordDisagreementPx(read.model, truth);
      char what[128];
      std::snprintf(what, sizeof what, "seed %d, 1/%d from (%d, %d)%s: %s, %.1e px", seed, c.s, c.ox, c.oy,
                    c.written_in_detector ? " in detector pixels" : "", read.frame.c_str(), px);
      CHECK_TEXT(px < 1e-6, what);
    }
  }
}
