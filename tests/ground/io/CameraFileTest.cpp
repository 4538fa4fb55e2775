// Camera files: formats, round trips, and malformed input that must name the field. Files are written
// by the test into its scratch folder (no shared data needed).
#include <cmath>
#include <fstream>
#include <string>

#include "ground/cli/Cli.hpp"
#include "ground/io/CameraFile.hpp"
#include "tests/firmware_core/camera/TestModels.hpp"
#include "tests/ground/dataset/FileSizeLimit.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

std::string writeFile(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// The error message of reading `path`, or "" if it reads.
std::string errorOf(const std::string& path, int w = 0, int h = 0) {
  try {
    (void)io::readCameraFile(path, w, h);
  } catch (const cli::InputError& e) {
    return e.field() + ": " + e.what();
  }
  return "";
}

const char* const kPdsHead =
    "PDS_VERSION_ID = PDS3\nRECORD_BYTES = 64\n^IMAGE = 40\n"
    "GROUP = GEOMETRIC_CAMERA_MODEL\n  MODEL_TYPE = CAHVOR\n"
    "  MODEL_COMPONENT_ID = (\"C\",\"A\",\"H\",\"V\",\n     \"O\",\"R\")\n";

std::string pdsLabel(const std::string& c, const std::string& a, const std::string& h, const std::string& v,
                     const std::string& o, const std::string& r, bool end = true) {
  std::string t = kPdsHead;
  const std::string comps[] = {c, a, h, v, o, r};
  for (int i = 0; i < 6; ++i) {
    if (comps[i].empty()) continue;
    t += "  MODEL_COMPONENT_" + std::to_string(i + 1) + " = " + comps[i] + "\n";
  }
  t += "  REFERENCE_COORD_SYSTEM_NAME = ROVER_FRAME\nEND_GROUP = GEOMETRIC_CAMERA_MODEL\n";
  t += "OBJECT = IMAGE\n  LINES = 1024\n  LINE_SAMPLES = 1024\n  SAMPLE_TYPE = MSB_INTEGER\n  SAMPLE_BITS = "
       "16\n"
       "END_OBJECT = IMAGE\n";
  if (end) t += "END\n";
  return t;
}

const std::string kC = "(0.394318,-0.0582843,-1.23826)";
const std::string kA = "(0.276192,-0.889336,0.364419)";
const std::string kH = "(1262.81,-60.1316,185.71)";
const std::string kV = "(0.196974,-50.5533,1294.91)";
const std::string kO = "(0.156295,-0.929704,0.3335)";
const std::string kR = "(0.019876,-0.014281,0.020876)";

}  // namespace

TEST_GROUP(CameraFile){};

TEST(CameraFile, ReadsAPds3LabelWithContinuationLines) {
  const std::string dir = test::scratchDir("camera_file_pds");
  const std::string path = writeFile(dir, "ok.lbl", pdsLabel(kC, kA, kH, kV, kO, kR));
  const io::CameraFile f = io::readCameraFile(path);
  CHECK(f.format == io::CameraFileFormat::kPds3);
  CHECK(f.model.type == CameraType::kCahvor);
  CHECK(f.size_from_file);
  CHECK_EQUAL(1024, f.model.width);
  STRCMP_EQUAL("ROVER_FRAME", f.reference_frame.c_str());
  DOUBLES_EQUAL(1294.91, f.model.v.z(), 0.0);
  DOUBLES_EQUAL(0.020876, f.model.r.z(), 0.0);
}

TEST(CameraFile, JplTextRoundTripsThroughAFile) {
  const std::string dir = test::scratchDir("camera_file_text");
  for (const test::NamedModel& nm : test::syntheticModels()) {
    const std::string path = dir + "/m.cahvor";
    io::writeCameraModelFile(path, nm.model);
    const CameraModel back = io::readCameraModelFile(path);
    CHECK(back.type == nm.model.type);
    CHECK((back.h - nm.model.h).norm() == 0.0);
    CHECK((back.e - nm.model.e).norm() == 0.0);
    CHECK_EQUAL(nm.model.width, back.width);
  }
  // A file without a size takes the caller's.
  const std::string bare =
      writeFile(dir, "bare.cahvor", "C = 0 0 0\nA = 1 0 0\nH = 500 1000 0\nV = 500 0 1000\n");
  const io::CameraFile f = io::readCameraFile(bare, 640, 480);
  CHECK(!f.size_from_file);
  CHECK_EQUAL(640, f.model.width);
  CHECK_EQUAL(480, f.model.height);
}

// Written on a full disk (a 64-byte file-size limit): an error naming the file, the previous model byte for
// byte, no temporary left (temporary name + rename).
TEST(CameraFile, FailedWriteLeavesThePreviousFileWhole) {
  const std::string dir = test::scratchDir("camera_file_full");
  const std::string path = dir + "/m.cahvor";
  const CameraModel m = test::syntheticModels().front().model;
  io::writeCameraModelFile(path, m);
  const std::string before = test::fileBytes(path);
  CameraModel moved = m;
  moved.c.x() += 1.0;
  bool thrown = false;
  {
    test::FileSizeLimit full(64);
    try {
      io::writeCameraModelFile(path, moved);
    } catch (const cli::InputError& e) {
      thrown = std::string(e.what()).find(path) != std::string::npos;
    }
  }
  CHECK(thrown);
  CHECK(test::fileBytes(path) == before);
  CHECK(test::temporariesIn(dir).empty());
  io::writeCameraModelFile(path, moved);
  CHECK(io::readCameraModelFile(path).c == moved.c);
}

TEST(CameraFile, RescaledModelIsTheSameCameraInTheNewPixelFrame) {
  const CameraModel m = test::m2020Like(CahvoreKind::kFisheye, 0.0);
  const Vec2 offset(12.5, 7.25);
  const CameraModel s = io::rescaledModel(m, 2.0, offset, 640, 480);
  const Vec3 p = m.c + 8.0 * m.a + Vec3(0.5, -0.4, 0.3);
  Vec2 a, b;
  CHECK(project(m, p, a) == Status::kOk);
  CHECK(project(s, p, b) == Status::kOk);
  CHECK((a - (offset + 2.0 * b)).norm() < 1e-9);
}

// Malformed models and labels give an error that names the field.
TEST(CameraFile, MalformedLabelsNameTheField) {
  const std::string dir = test::scratchDir("camera_file_bad");
  struct Case {
    std::string name, text, field;
  };
  // Sizes read from a file are checked before they are narrowed to int or scaled.
  std::string huge_lines = pdsLabel(kC, kA, kH, kV, kO, kR);
  huge_lines.replace(huge_lines.find("  LINES = 1024"), 14, "  LINES = 4294967304");  // 2^32 + 8
  const std::string cahv_json =
      "{\"camera_model_type\": \"CAHV\", \"camera_model_component_list\": "
      "\"(0,0,0);(1,0,0);(500,1000,0);(500,0,1000)\", ";
  const Case cases[] = {
      {"lines.lbl", huge_lines, "IMAGE.LINES"},
      {"json-huge-size.json", cahv_json + "\"dimension\": [1e300, 1e300]}", "dimension"},
      {"json-negative-size.json", cahv_json + "\"dimension\": [-8, 6]}", "dimension"},
      {"missing.lbl", pdsLabel(kC, kA, "", kV, kO, kR), "MODEL_COMPONENT_3 (H)"},
      {"nan.lbl", pdsLabel(kC, "(0.276192,NaN,0.364419)", kH, kV, kO, kR), "MODEL_COMPONENT_2 (A)"},
      {"norm.lbl", pdsLabel(kC, "(0.5,-0.889336,0.364419)", kH, kV, kO, kR), "MODEL_COMPONENT_2 (A)"},
      {"hpar.lbl", pdsLabel(kC, kA, "(276.192,-889.336,364.419)", kV, kO, kR), "MODEL_COMPONENT_3 (H)"},
      {"vpar.lbl", pdsLabel(kC, kA, kH, "(-27.6192,88.9336,-36.4419)", kO, kR), "MODEL_COMPONENT_4 (V)"},
      {"short.lbl", pdsLabel(kC, kA, kH, "(0.196974,-50.5533)", kO, kR), "MODEL_COMPONENT_4 (V)"},
      {"truncated.lbl", pdsLabel(kC, kA, kH, kV, kO, kR, false), "END"},
      {"open.lbl", std::string(kPdsHead) + "  MODEL_COMPONENT_1 = (0.39,\n", "END"},
      {"nogroup.lbl", "PDS_VERSION_ID = PDS3\nOBJECT = IMAGE\nLINES = 4\nEND_OBJECT = IMAGE\nEND\n",
       "GEOMETRIC_CAMERA_MODEL"},
      {"text-missing.cahvor", "C = 0 0 0\nA = 1 0 0\nH = 500 1000 0\n", "V"},
      {"text-nan.cahvor", "C = 0 0 0\nA = 1 0 0\nH = 500 1000 0\nV = 500 0 nan\n", "V"},
      {"text-trunc.cahvor", "C = 0 0 0\nA = 1 0 0\nH = 500 1000 0\nV = 500 0", "V"},
      {"text-norm.cahvor", "C = 0 0 0\nA = 1 1 0\nH = 500 1000 0\nV = 500 0 1000\n", "A"},
      {"json-short.json",
       "{\"camera_model_type\": \"CAHVOR\", \"camera_model_component_list\": \"(0,0,0);(1,0,0)\"}",
       "camera_model_component_list (H)"},
      {"json-nan.json",
       "{\"camera_model_type\": \"CAHV\", \"camera_model_component_list\": "
       "\"(0,0,0);(1,0,0);(x,1000,0);(500,0,1000)\"}",
       "camera_model_component_list (H)"},
      {"json-bad.json", "{\"camera_model_type\": ", "json"},
  };
  for (const Case& c : cases) {
    const std::string msg = errorOf(writeFile(dir, c.name, c.text), 1024, 1024);
    std::printf("\n%-20s -> %s", c.name.c_str(), msg.c_str());
    CHECK_FALSE(msg.empty());
    CHECK_TEXT(msg.find(c.field) != std::string::npos, (c.name + ": " + msg).c_str());
  }
  std::printf("\n");
  CHECK(errorOf(dir + "/does-not-exist.cahvor").find("file") != std::string::npos);
}
