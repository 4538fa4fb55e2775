// areomap-camera as a process: exit codes (0 / 2 usage / 1 bad file), the --json contract keys, --size.
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

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
  for (const char* k : {"f_px", "x0_px", "y0_px", "omega_deg", "phi_deg", "kappa_deg", "center_m", "distortion",
                        "R_site_to_camera"}) {
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
