// The default path of areomap-traverse (no truth ties, no stops): DATASET --out DIR matches the sites
// itself and places them. A navcam-like camera (navcam's 45 deg field, its 18-pair tier and its angular
// pointing errors) at 256 x 256 pixels, on a terrain of 3 cm cells, so that a site renders and maps in
// about a minute of CPU. Each run asserts that the position error after is at most 0.2 % of the distance
// driven and below the a-priori one, and that a pair of sites left untied is said on the console as well as
// in report.json. Both groups are labelled long and run with AREOMAP_LONG_TESTS=1: TraverseDefaultPath, two
// sites on level ground (about 170 s of CPU); TraverseDefaultPathLong, three sites on seeds 21, 22, 23, each
// on level ground and on slopes up to 10 deg, and seeds 26 (level) and 27 (sloped), one test each (about
// 350 s of CPU each). No constant here was tuned on these seeds.
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include <nlohmann/json.hpp>

#include "tests/ground/traverse/ReportFiles.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

namespace {

using json = nlohmann::json;

// The navcam preset at a quarter of its pixels: the pointing errors (3-15 px at 1024) scaled with the pixel.
constexpr const char* kNavcamLike =
    "--preset traverse --camera navcam --size 256 256 --pointing-error-px 0.75 3.75 --cell-m 0.03 "
    "--extent-m 15 --check-points 800 --leg-min-m 9 --leg-max-m 12";

struct DefaultRun {
  bool ran = false;
  json report;
  std::string console;  // what areomap-traverse printed on stdout and stderr
};

// Simulates the traverse and maps it with areomap-traverse's defaults.
DefaultRun defaultRun(const std::string& name, const std::string& options) {
  DefaultRun run;
  const std::string dir = areomap::test::scratchDir(name);
  if (areomap::test::runTool("areomap-sim",
                             std::string(kNavcamLike) + " " + options + " --out " + dir + "/ds") != 0)
    return run;
  const std::string log = dir + "/console.txt";
  const int status = std::system((areomap::test::toolPath("areomap-traverse") + " " + dir + "/ds --out " +
                                  dir + "/out --quiet > " + log + " 2>&1")
                                     .c_str());
  std::ifstream in(log);
  run.console.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  run.report = areomap::test::readJson(dir + "/out/report.json");
  run.ran = status == 0 && !run.report.is_discarded();
  return run;
}

// The assertions every default run makes; true when every pair of sites was tied.
bool checkDefaultRun(const DefaultRun& run, const char* name) {
  CHECK_TEXT(run.ran, name);
  const json& t = run.report["traverse"];
  const double after = t["position_error_pct"].get<double>();
  const double apriori = t["position_error_apriori_pct"].get<double>();
  std::printf("\n  %s: %.1f m driven, position error %.3f %% after (%.3f m), %.3f %% a priori\n", name,
              t["distance_m"].get<double>(), after, t["position_error_m"].get<double>(), apriori);
  // Every pair printed before any check, so that a failing run still shows them all.
  bool all_tied = true;
  std::string unsaid;  // untied pairs the console does not name
  for (const json& p : t["site_pairs"]) {
    const std::string pair = p["site_a"].get<std::string>() + "-" + p["site_b"].get<std::string>();
    std::printf("  %s: %s, %d ties\n", pair.c_str(), p["status"].get<std::string>().c_str(),
                p["ties"].get<int>());
    if (p["status"] != "ok") {
      all_tied = false;
      // An untied pair is said on the console, not only in the report.
      if (run.console.find(pair + " untied") == std::string::npos) unsaid += pair + " ";
    }
  }
  CHECK_TEXT(unsaid.empty(), ("untied pairs not on the console: " + unsaid).c_str());
  CHECK_TEXT(after <= 0.2, name);
  CHECK_TEXT(after < apriori, name);
  return all_tied;
}

}  // namespace

TEST_GROUP(TraverseDefaultPath){};

TEST(TraverseDefaultPath, TwoNavcamLikeSitesAreTiedAndPlacedWithinATenthOfTheOdometrysError) {
  if (!areomap::test::longTestsWanted("two navcam-like sites")) return;
  const DefaultRun run = defaultRun("default-path-2", "--sites 2 --seed 5");
  CHECK_TRUE(checkDefaultRun(run, "seed 5, 2 sites, level"));
  const json& t = run.report["traverse"];
  CHECK_EQUAL(std::string("matched"), t["cross_site_ties_source"].get<std::string>());
  CHECK_EQUAL(std::string("cross_site_ties"), t["site"][1]["source"].get<std::string>());
  CHECK_TRUE(t["cross_site_ties"].get<int>() > 100);
  CHECK_TRUE(t["position_error_pct"].get<double>() < 0.1 * t["position_error_apriori_pct"].get<double>());
}

TEST_GROUP(TraverseDefaultPathLong){};

// One test per seed and ground, so that every run is made and reported whatever the others give (a test
// stops at its first failed check).
namespace {
void threeSites(int seed, bool sloped) {
  if (!areomap::test::longTestsWanted("a three-site navcam-like traverse")) return;
  const std::string name = "seed " + std::to_string(seed) + (sloped ? ", sloped" : ", level");
  const DefaultRun run =
      defaultRun("default-path-" + std::to_string(seed) + (sloped ? "-sloped" : ""),
                 "--sites 3 --seed " + std::to_string(seed) + (sloped ? " --max-slope-deg 10" : ""));
  checkDefaultRun(run, name.c_str());
}
}  // namespace

TEST(TraverseDefaultPathLong, Seed21Level) {
  threeSites(21, false);
}
TEST(TraverseDefaultPathLong, Seed21Sloped) {
  threeSites(21, true);
}
TEST(TraverseDefaultPathLong, Seed22Level) {
  threeSites(22, false);
}
TEST(TraverseDefaultPathLong, Seed22Sloped) {
  threeSites(22, true);
}
TEST(TraverseDefaultPathLong, Seed23Level) {
  threeSites(23, false);
}
TEST(TraverseDefaultPathLong, Seed23Sloped) {
  threeSites(23, true);
}

// Seeds not looked at while the cross-site matcher's pose hypotheses were developed (on 21-23).
TEST(TraverseDefaultPathLong, Seed26Level) {
  threeSites(26, false);
}
TEST(TraverseDefaultPathLong, Seed27Sloped) {
  threeSites(27, true);
}
