// areomap-traverse on a rendered tiny traverse of two sites (areomap-sim --preset traverse --camera tiny):
// both sites mapped with products, the sites matched, poses.csv, report.json with the contract's keys and
// the matcher's verdict, the merged map, the models in the traverse frame;
// a site whose dataset is broken is reported and the other still mapped; bad usage exits 2.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include <sys/wait.h>

#include <nlohmann/json.hpp>

#include "ground/dataset/Traverse.hpp"
#include "tests/ground/traverse/ReportFiles.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// A 2-site tiny traverse of 4 pairs a site (the preset's 8 cost each run twice the site passes and the
// cross-site matching, and nothing checked here needs them), rendered once.
std::string traverseDataset() {
  static std::string dir;
  if (dir.empty()) {
    dir = areomap::test::scratchDir(areomap::test::kTraverseToolDataset) + "/ds";
    if (areomap::test::runTool(
            "areomap-sim",
            "--preset traverse --camera tiny --pairs 4 --sites 2 --seed 3 --leg-min-m 10 --leg-max-m 12 --out " +
                dir) != 0)
      dir = "";
  }
  return dir;
}

using areomap::test::lines;
using areomap::test::readJson;

// A file's bytes; a site's report.json without its stage times ("seconds": they differ from run to run).
std::string productBytes(const fs::path& path, const std::string& rel) {
  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (rel.rfind("sites/", 0) != 0 || path.filename() != "report.json") return bytes;
  json r = json::parse(bytes, nullptr, false);
  r.erase("seconds");
  return r.dump();
}

// The name of the first file that differs between two runs' folders (one only in either counts), "" when
// every product is the same; left out: logs/ and the sites' manifest.json (it checksums report.json).
std::string firstDifference(const std::string& a, const std::string& b) {
  std::map<std::string, int> seen;
  for (const std::string& root : {a, b})
    for (const fs::directory_entry& e : fs::recursive_directory_iterator(root)) {
      const std::string rel = fs::relative(e.path(), root).generic_string();
      if (e.is_regular_file() && rel.rfind("logs/", 0) != 0 && e.path().filename() != "manifest.json")
        seen[rel] += 1;
    }
  for (const auto& [rel, count] : seen)
    if (count != 2 || productBytes(a + "/" + rel, rel) != productBytes(b + "/" + rel, rel)) return rel;
  return seen.empty() ? "(no files)" : "";
}

}  // namespace

TEST_GROUP(TraverseTool){};

TEST(TraverseTool, MapsEverySiteAndWritesThePosesAndTheReport) {
  const std::string ds = traverseDataset();
  CHECK_FALSE(ds.empty());
  // The whole default run: every site's pass with products, the cross-site matching between the sites'
  // products, the poses, the merged map.
  const std::string out = areomap::test::scratchDir(areomap::test::kTraverseToolOut);
  CHECK_EQUAL(0, areomap::test::runTool("areomap-traverse", ds + " --out " + out + " --quiet"));
  CHECK_EQUAL(3, lines(out + "/poses.csv"));  // header + 2 sites
  for (const char* f : {"dem.tif", "dem_sigma.tif", "ortho.tif", "cross_ties.json", "sites/site02/dem.tif"})
    CHECK_TEXT(fs::exists(out + "/" + f), f);
  const json r = readJson(out + "/report.json");
  CHECK_FALSE(r.is_discarded());
  const json& t = r["traverse"];
  CHECK_EQUAL(2, t["sites"].get<int>());
  for (const char* key : {"distance_m", "position_error_m", "position_error_pct",
                          "position_error_apriori_pct", "cross_site_ties"}) {
    CHECK_TEXT(t.contains(key), key);
  }
  CHECK_TRUE(t["distance_m"].get<double>() >= 10.0 && t["distance_m"].get<double>() <= 12.0);
  CHECK_TRUE(t["position_error_apriori_pct"].get<double>() > 0.0);  // odometry drift against the truth
  for (const json& s : t["site"]) CHECK_TRUE(s["mapped"].get<bool>());
  CHECK_TRUE(r["method1_px"].get<double>() < 0.5);
  // The matcher's verdict on the one pair of sites is in the report and in cross_ties.json; the second
  // site's pose comes from the ties when the pair gave any, else from the odometry with a warning.
  CHECK_EQUAL(std::string("matched"), t["cross_site_ties_source"].get<std::string>());
  CHECK_EQUAL(1u, t["site_pairs"].size());
  const json& pair = t["site_pairs"][0];
  CHECK_EQUAL(std::string("site01"), pair["site_a"].get<std::string>());
  CHECK_EQUAL(std::string("site02"), pair["site_b"].get<std::string>());
  const json matched = readJson(out + "/cross_ties.json");
  CHECK_EQUAL(pair["status"].get<std::string>(), matched["pairs"][0]["status"].get<std::string>());
  std::printf("\n  site01-site02: %s, %d ties; position error %.3f m (a priori %.3f m)\n",
              pair["status"].get<std::string>().c_str(), pair["ties"].get<int>(),
              t["position_error_m"].get<double>(), t["position_error_apriori_m"].get<double>());
  if (pair["status"] == "ok") {
    // Tied (the tiny camera's DEMs are too noisy to register; its orthoimages register instead): the second
    // site lands closer to its true position than the odometry put it.
    CHECK_TRUE(pair["ties"].get<int>() > 0 && t["cross_site_ties"].get<int>() > 0);
    CHECK_EQUAL(std::string("cross_site_ties"), t["site"][1]["source"].get<std::string>());
    CHECK_TRUE(t["position_error_m"].get<double>() < t["position_error_apriori_m"].get<double>());
  } else {
    CHECK_TRUE(pair.contains("message"));
    std::printf("  %s\n", pair["message"].get<std::string>().c_str());
    // A refused DEM registration says why in the data's figures: on the tiny camera's own products the DEMs
    // differ by about twice what their dem_sigma layers give, and the relief they share changes their
    // differences by a fraction of that (docs/traverse.md "Limits").
    if (pair["status"] == "registration_failed") {
      const std::string message = pair["message"].get<std::string>();
      CHECK_TRUE(message.find("dem_sigma layers give") != std::string::npos ||
                 message.find("the relief they share changes") != std::string::npos);
      const json& g = matched["pairs"][0]["registration"];
      for (const char* key : {"difference_rms_m", "dem_sigma_rms_m", "relief_signal_m", "drift"})
        CHECK_TEXT(g.contains(key), key);
    }
    CHECK_EQUAL(std::string("odometry"), t["site"][1]["source"].get<std::string>());
    CHECK_TRUE(r["warnings"].dump().find("odometry") != std::string::npos);
  }
  CHECK_TRUE(fs::exists(out + "/sites/site01/models") && fs::exists(out + "/models/site02"));
}

TEST(TraverseTool, CrossSiteTiesPlaceTheSites) {
  // Cross-site ties from the truth (0.3 px noise): the multi-site adjustment moves the second site from its
  // odometry pose (metres off) to within a fraction of it; what is left is mostly the first site's own
  // pointing datum (its adjusted cameras' common rotation, ~0.3 deg on the tiny camera), which turns the
  // whole traverse frame about it.
  const std::string ds = traverseDataset();
  CHECK_FALSE(ds.empty());
  const std::string out = areomap::test::scratchDir("traverse-tool-ties");
  CHECK_EQUAL(0, areomap::test::runTool("areomap-traverse",
                                        ds + " --out " + out + " --truth-cross-ties --no-products --quiet"));
  const json r = readJson(out + "/report.json");
  const json& t = r["traverse"];
  const double after = t["position_error_m"].get<double>(),
               before = t["position_error_apriori_m"].get<double>();
  std::printf(
      "\n  position error %.3f m after, %.3f m a priori; %d cross-site observations, method 1 %.3f px\n",
      after, before, t["cross_site_ties"].get<int>(), t["cross_site_method1_px"].get<double>());
  CHECK_EQUAL(std::string("cross_site_ties"), t["site"][1]["source"].get<std::string>());
  CHECK_TRUE(after < 0.3 * before);
  CHECK_TRUE(t["cross_site_ties"].get<int>() > 100);
  CHECK_TRUE(t["cross_site_method1_px"].get<double>() < 0.6);
  CHECK_TRUE(fs::exists(out + "/cross_ties.csv"));
  // The pose's sigmas are honest: they carry the first site's datum (its cameras' common rotation, known
  // from its pass's pointing corrections: ~15 mrad on this camera), which turns every tied pose about it.
  const areomap::Traverse traverse = areomap::readTraverse(ds);
  const areomap::TraverseTruth truth = *areomap::readTraverseTruth(ds, traverse);
  const json& site = t["site"][1];
  CHECK_TRUE(site.contains("datum_sigma_mrad") && t["site"][0].contains("datum_sigma_mrad"));
  for (int a = 0; a < 3; ++a) {
    const double error = site["position_m"][a].get<double>() - truth.poses[1].position_m[a];
    const double sigma = site["sigma_m"][a].get<double>();
    std::printf("  axis %d: error %+.3f m, sigma %.3f m\n", a, error, sigma);
    CHECK_TRUE(std::fabs(error) <= 3.0 * sigma);
  }
}

TEST(TraverseTool, ATraversingStopIsASiteOfItsOwnAndTiesTheSitesAroundIt) {
  // Two tiny sites 10-12 m apart with a traversing stop half way (a forward-looking pair or two): three
  // sites in driving order, the stop mapped like the others, tied, and reported as a stop; the position
  // figures over the panorama sites alone besides those over every site.
  const std::string ds = areomap::test::scratchDir("traverse-tool-stop") + "/ds";
  CHECK_EQUAL(0, areomap::test::runTool("areomap-sim",
                                        "--preset traverse --camera tiny --sites 2 --seed 4 "
                                        "--leg-min-m 10 --leg-max-m 12 --stop-spacing-m 7 "
                                        "--out " +
                                            ds));
  const areomap::Traverse traverse = areomap::readTraverse(ds);
  CHECK_EQUAL(3u, traverse.sites.size());
  CHECK_EQUAL(std::string("stop01-1"), traverse.sites[1].id);
  CHECK_TRUE(traverse.sites[1].kind == areomap::SiteKind::kStop);
  const std::string out = areomap::test::scratchDir("traverse-tool-stop-out");
  CHECK_EQUAL(0, areomap::test::runTool("areomap-traverse",
                                        ds + " --out " + out + " --truth-cross-ties --no-products --quiet"));
  CHECK_EQUAL(4, lines(out + "/poses.csv"));
  const json r = readJson(out + "/report.json");
  const json& t = r["traverse"];
  CHECK_EQUAL(3, t["sites"].get<int>());
  CHECK_EQUAL(1, t["stops"].get<int>());
  CHECK_EQUAL(std::string("stop"), t["site"][1]["kind"].get<std::string>());
  CHECK_EQUAL(std::string("panorama"), t["site"][2]["kind"].get<std::string>());
  for (int k = 1; k < 3; ++k) {
    CHECK_TRUE(t["site"][k]["mapped"].get<bool>());
    CHECK_EQUAL(std::string("cross_site_ties"), t["site"][k]["source"].get<std::string>());
  }
  CHECK_TRUE(t.contains("position_error_panorama_sites_m") &&
             t.contains("position_error_panorama_sites_pct"));
  const double after = t["position_error_m"].get<double>(),
               before = t["position_error_apriori_m"].get<double>();
  std::printf("\n  with a stop: position error %.3f m after, %.3f m a priori (panorama sites: %.3f m)\n",
              after, before, t["position_error_panorama_sites_m"].get<double>());
  CHECK_TRUE(after < 0.5 * before);
}

TEST(TraverseTool, ABrokenSiteIsReportedAndTheOtherMapped) {
  const std::string ds = traverseDataset();
  CHECK_FALSE(ds.empty());
  const std::string copy = areomap::test::scratchDir("traverse-tool-broken") + "/ds";
  fs::copy(ds, copy, fs::copy_options::recursive);
  {
    std::ofstream bad(copy + "/sites/site02/panorama.json");
    bad << "{ \"version\": 1, \"pairs\": [";  // truncated
  }
  const std::string out = copy + "-out";
  CHECK_EQUAL(0,
              areomap::test::runTool("areomap-traverse", copy + " --out " + out + " --no-products --quiet"));
  const json r = readJson(out + "/report.json");
  CHECK_TRUE(r["traverse"]["site"][0]["mapped"].get<bool>());
  CHECK_FALSE(r["traverse"]["site"][1]["mapped"].get<bool>());
  CHECK_TRUE(r["traverse"]["site"][1]["error"].get<std::string>().find("panorama.json") != std::string::npos);
}

TEST(TraverseTool, SitePassesAsJobsGiveTheSerialRunsProducts) {
  // The same traverse site after site in one process, as child processes two at a time, and by hand a
  // site's own command (--site) then the cross-site step (--join): the same products, byte for byte.
  const std::string ds = traverseDataset();
  CHECK_FALSE(ds.empty());
  const std::string dir = areomap::test::scratchDir("traverse-tool-jobs");
  const std::string opts = " --no-products --truth-cross-ties --quiet";
  CHECK_EQUAL(0, areomap::test::runTool("areomap-traverse", ds + " --out " + dir + "/serial --jobs 1" + opts));
  CHECK_EQUAL(0, areomap::test::runTool("areomap-traverse", ds + " --out " + dir + "/jobs --jobs 2" + opts));
  STRCMP_EQUAL("", firstDifference(dir + "/serial", dir + "/jobs").c_str());
  CHECK_TRUE(fs::exists(dir + "/jobs/logs/site-2.log"));
  // By hand: the serial run's site01 (complete), site02 mapped by its own command, then the join.
  fs::create_directories(dir + "/hand/sites");
  fs::copy(dir + "/serial/sites/site01", dir + "/hand/sites/site01", fs::copy_options::recursive);
  CHECK_EQUAL(0, areomap::test::runTool("areomap-traverse",
                                        ds + " --out " + dir + "/hand --site site02 --no-products --quiet"));
  CHECK_EQUAL(0, areomap::test::runTool("areomap-traverse", ds + " --out " + dir + "/hand --join" + opts));
  STRCMP_EQUAL("", firstDifference(dir + "/serial", dir + "/hand").c_str());
  // --resume: a product written again since its pass (other bytes) makes that site be mapped again, alone;
  // the complete site is left as it is.
  const std::string site01_manifest = dir + "/jobs/sites/site01/manifest.json";
  const auto site01_time = fs::last_write_time(site01_manifest);
  std::ofstream(dir + "/jobs/sites/site02/eo.csv", std::ios::app) << "half written\n";
  CHECK_EQUAL(0, areomap::test::runTool("areomap-traverse", ds + " --out " + dir + "/jobs --jobs 2 --resume" + opts));
  CHECK_TRUE(site01_time == fs::last_write_time(site01_manifest));
  STRCMP_EQUAL("", firstDifference(dir + "/serial", dir + "/jobs").c_str());
  // The cross-site step refuses a site without a complete pass, naming it.
  fs::remove(dir + "/hand/sites/site02/manifest.json");
  CHECK_EQUAL(1, areomap::test::runTool("areomap-traverse", ds + " --out " + dir + "/hand --join" + opts));
}

TEST(TraverseTool, ASiteJobThatFailsKeepsTheCrossSiteStepFromRunning) {
  // A site's folder that cannot be made (a file is in its place) fails that site's job: no cross-site step,
  // report.json "incomplete" with the site and the reason, exit 1; the other site is mapped and complete.
  const std::string ds = traverseDataset();
  CHECK_FALSE(ds.empty());
  const std::string out = areomap::test::scratchDir("traverse-tool-job-fails") + "/out";
  fs::create_directories(out + "/sites");
  std::ofstream(out + "/sites/site02") << "not a folder\n";
  CHECK_EQUAL(1, areomap::test::runTool("areomap-traverse", ds + " --out " + out + " --jobs 2 --no-products --quiet"));
  const json r = readJson(out + "/report.json");
  STRCMP_EQUAL("incomplete", r["status"].get<std::string>().c_str());
  CHECK_TRUE(r["traverse"]["site"][0]["mapped"].get<bool>());
  const std::string reason = r["traverse"]["site"][1]["job_failed"]["reason"].get<std::string>();
  CHECK_TRUE(reason.find("not a folder") != std::string::npos);
  CHECK_FALSE(fs::exists(out + "/poses.csv"));
  CHECK_TRUE(r["resume"].get<std::string>().find("--resume") != std::string::npos);
}

TEST(TraverseTool, BadUsageAndMissingTraverse) {
  const std::string dir = areomap::test::scratchDir("traverse-tool-usage");
  CHECK_EQUAL(2, areomap::test::runTool("areomap-traverse", dir));  // no --out
  // No traverse.json there: exit 1, the message naming the file (runTool discards the output).
  const int status = std::system(
      (areomap::test::toolPath("areomap-traverse") + " " + dir + " --out " + dir + "/o 2> " + dir + "/err")
          .c_str());
  CHECK_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1);
  std::ifstream err(dir + "/err");
  const std::string text((std::istreambuf_iterator<char>(err)), std::istreambuf_iterator<char>());
  CHECK_TRUE(text.find("traverse.json") != std::string::npos);
  CHECK_EQUAL(0, areomap::test::runTool("areomap-traverse", "--help"));
  CHECK_EQUAL(2, areomap::test::runTool("areomap-traverse",
                                        dir + " --out " + dir + "/o --no-cross-ties --truth-cross-ties"));
  CHECK_EQUAL(2, areomap::test::runTool("areomap-traverse", dir + " --out " + dir + "/o --executor pbs"));
  CHECK_EQUAL(2, areomap::test::runTool("areomap-traverse", dir + " --out " + dir + "/o --partition p"));
  CHECK_EQUAL(2, areomap::test::runTool("areomap-traverse", dir + " --out " + dir + "/o --site 1 --join"));
  CHECK_EQUAL(2, areomap::test::runTool("areomap-traverse", dir + " --out " + dir + "/o --jobs 0"));
}
