#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <sys/wait.h>
#include <vector>

#include "platform/heap/HeapCounter.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

namespace {

std::string binDir() {
  const char* env = std::getenv("AREOMAP_BINARY_DIR");
  return std::string(env != nullptr ? env : ".") + "/bin";
}

int runTool(const std::string& command) {
  const int status = std::system((command + " > /dev/null 2>&1").c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

// One tiny simulated dataset (geometry and truth only) shared by the tests of this group.
const std::string& tinyDataset() {
  static std::string dir;
  if (dir.empty()) {
    dir = areomap::test::scratchDir("adjust-tool-tiny");
    const int rc = runTool(binDir() + "/areomap-sim --preset tiny --no-images --threads 1 --out " + dir);
    if (rc != 0) std::printf("areomap-sim failed: %d\n", rc);
  }
  return dir;
}

int countLines(const std::string& path) {
  std::ifstream in(path);
  int n = 0;
  std::string line;
  while (std::getline(in, line)) n += line.empty() ? 0 : 1;
  return n;
}

}  // namespace

TEST_GROUP(AdjustTool){};

TEST(AdjustTool, EverySolverWritesTheEoSigmasOfItsSolution) {
  const std::string data = tinyDataset();
  std::vector<std::array<double, 6>> sigmas[3];
  const char* solvers[3] = {"fast", "svd", "ceres"};
  for (int k = 0; k < 3; ++k) {
    const std::string out = areomap::test::scratchDir(std::string("adjust-tool-sigma-") + solvers[k]);
    CHECK_EQUAL(0, runTool(binDir() + "/areomap-adjust " + data + " --out " + out +
                           " --truth-ties --noise-px 0.3 --seed 5 --max-sweeps 2000 --solver " + solvers[k]));
    sigmas[k] = areomap::test::readEoSigmas(out + "/eo.csv");
  }
  CHECK(sigmas[0].size() >= 16);
  double worst = 0.0;
  for (int k = 0; k < 3; ++k) {
    CHECK_EQUAL(sigmas[0].size(), sigmas[k].size());
    for (std::size_t i = 0; i < sigmas[k].size(); ++i) {
      for (int c = 0; c < 6; ++c) {
        CHECK_TEXT(sigmas[k][i][c] > 0.0, solvers[k]);
        worst = std::fmax(worst, std::fabs(sigmas[k][i][c] / sigmas[0][i][c] - 1.0));
      }
    }
  }
  std::printf(
      "\n  tiny eo.csv: image 0 sigmas %.2e %.2e %.2e m %.2e %.2e %.2e rad; largest relative difference "
      "of svd / ceres from fast %.2e\n",
      sigmas[0][0][0], sigmas[0][0][1], sigmas[0][0][2], sigmas[0][0][3], sigmas[0][0][4], sigmas[0][0][5],
      worst);
  CHECK(worst < 0.01);  // one solution (to the solvers' tolerances), one covariance
}

TEST(AdjustTool, TruthTiesGiveTheProductsAndBetterFigures) {
  const std::string data = tinyDataset();
  const std::string out = areomap::test::scratchDir("adjust-tool-out");
  CHECK_EQUAL(0, runTool(binDir() + "/areomap-adjust " + data + " --out " + out +
                         " --truth-ties --noise-px 0.3 --seed 3"));
  std::ifstream in(out + "/report.json");
  const nlohmann::json r = nlohmann::json::parse(in);
  for (const char* key : {"method1_px", "method2_m", "method3_px", "rms_px", "sigma0", "iterations",
                          "tie_points", "seconds", "truth", "warnings"}) {
    CHECK_TEXT(r.contains(key), key);
  }
  const double m1_before = r["method1_px"]["before"]["dist"];
  const double m1_after = r["method1_px"]["after"]["dist"];
  const double eo_before = r["truth"]["eo_px_before"];
  const double eo_after = r["truth"]["eo_px"];
  std::printf(
      "\n  tiny via areomap-adjust: method 1 %.3f -> %.3f px, EO vs truth %.3f -> %.3f px (aligned), "
      "raw %.3f px, rms %.3f px, sigma0 %.3f\n",
      m1_before, m1_after, eo_before, eo_after, r["truth"]["eo_px_raw"].get<double>(),
      r["rms_px"].get<double>(), r["sigma0"].get<double>());
  CHECK(m1_after < 0.5 * m1_before);
  CHECK(eo_after < eo_before / 5.0);
  CHECK(r["rms_px"].get<double>() < 0.35);
  CHECK(r["tie_points"]["inter"].get<int>() > 0);
  // One adjusted model and one eo.csv row per image.
  int models = 0;
  for (const auto& e : std::filesystem::directory_iterator(out + "/models"))
    models += e.path().extension() == ".cahvor";
  CHECK(models >= 16);
  CHECK_EQUAL(models + 1, countLines(out + "/eo.csv"));
}

TEST(AdjustTool, IntegratedSolversAgreeWithTheFastOne) {
  const std::string data = tinyDataset();
  const std::string a = areomap::test::scratchDir("adjust-tool-fast");
  const std::string b = areomap::test::scratchDir("adjust-tool-ceres");
  CHECK_EQUAL(
      0, runTool(binDir() + "/areomap-adjust " + data + " --out " + a + " --truth-ties --max-sweeps 2000"));
  CHECK_EQUAL(0,
              runTool(binDir() + "/areomap-adjust " + data + " --out " + b + " --truth-ties --solver ceres"));
  std::ifstream ia(a + "/report.json"), ib(b + "/report.json");
  const nlohmann::json ra = nlohmann::json::parse(ia), rb = nlohmann::json::parse(ib);
  const double ea = ra["truth"]["eo_px"], eb = rb["truth"]["eo_px"];
  std::printf("\n  tiny EO vs truth: fast %.4f px, ceres %.4f px\n", ea, eb);
  DOUBLES_EQUAL(eb, ea, 0.01);
}

TEST(AdjustTool, ExitCodesFollowTheContract) {
  const std::string data = tinyDataset();
  const std::string out = areomap::test::scratchDir("adjust-tool-bad");
  CHECK_EQUAL(0, runTool(binDir() + "/areomap-adjust --help"));
  CHECK_EQUAL(2, runTool(binDir() + "/areomap-adjust " + data + " --truth-ties"));  // no --out
  CHECK_EQUAL(2, runTool(binDir() + "/areomap-adjust " + data + " --out " + out));  // no ties
  CHECK_EQUAL(2,
              runTool(binDir() + "/areomap-adjust " + data + " --out " + out + " --truth-ties --solver x"));
  CHECK_EQUAL(
      2, runTool(binDir() + "/areomap-adjust " + data + " --out " + out + " --truth-ties --fast-method x"));
  CHECK_EQUAL(0, runTool(binDir() + "/areomap-adjust " + data + " --out " + out +
                         " --truth-ties --fast-method alternation"));
  CHECK_EQUAL(1, runTool(binDir() + "/areomap-adjust " + out + "/missing --out " + out + " --truth-ties"));
  // A tie list whose observations leave an image without points: a degenerate network, exit 1.
  const std::string ties = out + "/ties.csv";
  {
    std::ofstream t(ties);
    t << "point,image,sample_px,line_px\n";
  }
  CHECK_EQUAL(1, runTool(binDir() + "/areomap-adjust " + data + " --out " + out + " --ties " + ties));
}
