// areomap-camera as a process: exit codes (0 / 2 usage / 1 bad file), the --json contract keys, --size.
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

namespace {

std::string tool() {
  const char* env = std::getenv("AREOMAP_BINARY_DIR");
  return std::string(env != nullptr ? env : ".") + "/bin/areomap-camera";
}

// Runs the tool; returns its exit code, stdout and stderr in the two strings.
int runTool(const std::string& args, std::string& out, std::string& err, const std::string& scratch) {
  const std::string o = scratch + "/out.txt", e = scratch + "/err.txt";
  const int status = std::system((tool() + " " + args + " >" + o + " 2>" + e).c_str());
  std::ifstream fo(o), fe(e);
  std::stringstream so, se;
  so << fo.rdbuf();
  se << fe.rdbuf();
  out = so.str();
  err = se.str();
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

}  // namespace

TEST_GROUP(CameraTool){};

TEST(CameraTool, ExitCodesAndJsonContract) {
  if (!areomap::test::fileExists(tool())) {
    std::printf("\nSKIP: %s not built\n", tool().c_str());
    return;
  }
  const std::string scratch = areomap::test::scratchDir("camera_tool");
  std::string out, err;
  CHECK_EQUAL(0, runTool("--help", out, err, scratch));
  CHECK(out.find("usage: areomap-camera") != std::string::npos);
  CHECK_EQUAL(2, runTool("", out, err, scratch));
  CHECK_EQUAL(2, runTool("a b", out, err, scratch));
  CHECK_EQUAL(1, runTool(scratch + "/missing.cahvor", out, err, scratch));
  CHECK(err.find("missing.cahvor") != std::string::npos);

  const std::string bad = scratch + "/bad.cahvor";
  std::ofstream(bad) << "C = 0 0 0\nA = 1 0 0\nH = 500 1000 0\n";
  CHECK_EQUAL(1, runTool(bad + " --json", out, err, scratch));
  CHECK(err.find("bad.cahvor") != std::string::npos);
  CHECK(err.find("V") != std::string::npos);

  const std::string good = scratch + "/good.cahvor";
  std::ofstream(good) << "C = 1 2 3\nA = 1 0 0\nH = 320 800 0\nV = 240 0 800\nO = 1 0 0\nR = 0 -0.01 0.002\n";
  CHECK_EQUAL(0, runTool(good + " --json", out, err, scratch));
  CHECK(err.find("warning") != std::string::npos);  // no size: 1024 x 1024 with a warning
  nlohmann::json j = nlohmann::json::parse(out);
  CHECK_EQUAL(1024, j["model"]["width"].get<int>());
  CHECK_EQUAL(0, runTool(good + " --json --size 640 480", out, err, scratch));
  j = nlohmann::json::parse(out);
  CHECK_EQUAL(640, j["model"]["width"].get<int>());
  CHECK_EQUAL(480, j["model"]["height"].get<int>());
  STRCMP_EQUAL("CAHVOR", j["model"]["type"].get<std::string>().c_str());
  for (const char* k : {"C", "A", "H", "V", "O", "R"}) CHECK_EQUAL(3u, j["model"][k].size());
  CHECK(!j["model"].contains("E"));
  for (const char* k : {"f_px", "x0_px", "y0_px", "omega_deg", "phi_deg", "kappa_deg", "center_m",
                        "distortion", "R_site_to_camera"}) {
    CHECK_TEXT(j["photogrammetric"].contains(k), k);
  }
  CHECK_EQUAL(3u, j["photogrammetric"]["R_site_to_camera"].size());
  DOUBLES_EQUAL(800.0, j["photogrammetric"]["f_px"].get<double>(), 1e-9);
  DOUBLES_EQUAL(320.0, j["photogrammetric"]["x0_px"].get<double>(), 1e-9);
  DOUBLES_EQUAL(2.0, j["photogrammetric"]["center_m"][1].get<double>(), 0.0);
  CHECK(j["conversion_residual_px"]["rms"].get<double>() < 0.05);
  CHECK(j["conversion_residual_px"]["max"].get<double>() < 0.25);
  CHECK_EQUAL(2, runTool(good + " --size 640", out, err, scratch));
}

// M2020 JSON frames through the tool: a delivered-frame subframe (principal point near the left edge) is
// printed as given; a full-resolution model with a 1/8 PNG beside it is scaled by 8 (the PNG's size wins
// over "dimension", with a warning on stderr and in "warnings"); a model that fits no frame exits 1 naming
// the file, the field and the frames tried.
TEST(CameraTool, M2020FramesAndTheImageBeside) {
  if (!areomap::test::fileExists(tool())) {
    std::printf("\nSKIP: %s not built\n", tool().c_str());
    return;
  }
  const std::string scratch = areomap::test::scratchDir("camera_tool_m2020");
  auto json = [](double hc, double vc, double f, int w, int h, int scale, int first_x) {
    return "{\"camera_model_type\": \"CAHV\", \"camera_model_component_list\": \"(0,0,0);(1,0,0);(" +
           std::to_string(hc) + "," + std::to_string(f) + ",0);(" + std::to_string(vc) + ",0," +
           std::to_string(f) + ")\", \"dimension\": \"(" + std::to_string(w) + "," + std::to_string(h) +
           ")\", \"scale_factor\": " + std::to_string(scale) + ", \"subframe_rect\": [" +
           std::to_string(first_x) + ", 1, 2576, 1936]}";
  };
  std::string out, err;
  const std::string sub = scratch + "/sub-metadata.json";
  std::ofstream(sub) << json(20.0, 960.0, 1480.0, 1288, 968, 2, 2545);
  CHECK_EQUAL(0, runTool(sub + " --json", out, err, scratch));
  nlohmann::json j = nlohmann::json::parse(out);
  STRCMP_EQUAL("as given", j["scale_to_image"]["frame"].get<std::string>().c_str());
  DOUBLES_EQUAL(20.0, j["photogrammetric"]["x0_px"].get<double>(), 1e-9);

  // Full resolution 5152 x 3872 (principal point 2590, 1950); the JSON says 1288 x 968, the PNG is 644 x 484.
  const std::string thumb = scratch + "/thumb-metadata.json";
  std::ofstream(thumb) << json(2590.0, 1950.0, 2960.0, 1288, 968, 1, 1);
  CHECK(cv::imwrite(scratch + "/thumb.png", cv::Mat(484, 644, CV_8UC1, cv::Scalar(7))));
  CHECK_EQUAL(0, runTool(thumb + " --json", out, err, scratch));
  j = nlohmann::json::parse(out);
  CHECK(err.find("thumb.png is 644x484") != std::string::npos);
  CHECK_EQUAL(1u, j["warnings"].size());
  DOUBLES_EQUAL(8.0, j["scale_to_image"]["scale"].get<double>(), 0.0);
  CHECK_EQUAL(644, j["model"]["width"].get<int>());
  CHECK_EQUAL(5152, j["model_in_file"]["width"].get<int>());
  DOUBLES_EQUAL((2590.0 - 3.5) / 8.0, j["photogrammetric"]["x0_px"].get<double>(), 1e-9);
  DOUBLES_EQUAL(2960.0 / 8.0, j["photogrammetric"]["f_px"].get<double>(), 1e-9);

  const std::string none = scratch + "/none-metadata.json";
  std::ofstream(none) << json(-4000.0, 960.0, 1480.0, 1288, 968, 1, 1);
  CHECK_EQUAL(1, runTool(none + " --json", out, err, scratch));
  for (const char* part :
       {"none-metadata.json", "camera_model_component_list (H, V)", "1288x968", "tried as given"}) {
    CHECK_TEXT(err.find(part) != std::string::npos, part);
  }
}
