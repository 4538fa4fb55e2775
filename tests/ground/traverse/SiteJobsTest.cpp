// A site's manifest (ground/traverse/SiteManifest.hpp): complete only while every file matches it; and the
// command lines of the site jobs (ground/traverse/SiteJobs.hpp) as a shell reads them back.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "ground/cli/Process.hpp"
#include "ground/traverse/SiteJobs.hpp"
#include "ground/traverse/SiteManifest.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

namespace fs = std::filesystem;
using areomap::traverse::checkSiteManifest;
using areomap::traverse::SiteRecord;
using areomap::traverse::writeSiteManifest;

namespace {

void writeText(const std::string& path, const std::string& text) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

// A site folder with two products and its manifest.
std::string siteFolder(const std::string& name) {
  const std::string dir = areomap::test::scratchDir(name) + "/site02";
  writeText(dir + "/eo.csv", "stem,x\np000_L,1.0\n");
  writeText(dir + "/models/p000_L.cahvor", "C = 0 0 0\n");
  writeSiteManifest(dir, "site02", true, "");
  return dir;
}

}  // namespace

TEST_GROUP(SiteManifest){};

TEST(SiteManifest, CompleteWhileEveryFileMatches) {
  const std::string dir = siteFolder("site-manifest-ok");
  const SiteRecord r = checkSiteManifest(dir, "site02");
  CHECK_TRUE(r.complete);
  CHECK_TRUE(r.mapped);
  CHECK_FALSE(checkSiteManifest(dir, "site03").complete);  // another site's folder
}

TEST(SiteManifest, AChangedAddedOrMissingFileMakesItIncomplete) {
  const std::string dir = siteFolder("site-manifest-changed");
  writeText(dir + "/eo.csv", "stem,x\np000_L,2.0\n");  // same size, other bytes
  SiteRecord r = checkSiteManifest(dir, "site02");
  CHECK_FALSE(r.complete);
  STRCMP_EQUAL("eo.csv: checksum", r.why_not.c_str());
  writeText(dir + "/eo.csv", "stem,x\np000_L,1.0\n");
  CHECK_TRUE(checkSiteManifest(dir, "site02").complete);
  writeText(dir + "/dem.tif", "half");  // a file of a later pass, not in the manifest
  CHECK_FALSE(checkSiteManifest(dir, "site02").complete);
  fs::remove(dir + "/dem.tif");
  fs::remove(dir + "/models/p000_L.cahvor");
  CHECK_FALSE(checkSiteManifest(dir, "site02").complete);
  fs::remove(dir + "/manifest.json");
  r = checkSiteManifest(dir, "site02");
  CHECK_FALSE(r.complete);
  STRCMP_EQUAL("no manifest.json", r.why_not.c_str());
}

TEST(SiteManifest, ASiteNotMappedKeepsItsReason) {
  const std::string dir = areomap::test::scratchDir("site-manifest-failed") + "/site03";
  fs::create_directories(dir);
  writeSiteManifest(dir, "site03", false, "panorama.json: not valid JSON");
  const SiteRecord r = checkSiteManifest(dir, "site03");
  CHECK_TRUE(r.complete);
  CHECK_FALSE(r.mapped);
  STRCMP_EQUAL("panorama.json: not valid JSON", r.error.c_str());
}

TEST_GROUP(SiteJobs){};

TEST(SiteJobs, AShellReadsTheCommandLineBack) {
  const std::vector<std::string> argv = {"printf", "%s\\n", "plain", "with space", "it's", "$HOME", "a\"b", ""};
  const areomap::cli::ProcessOutput r = areomap::cli::runProcess({"sh", "-c", areomap::traverse::shellLine(argv)});
  CHECK_TRUE(r.exit.ok());
  STRCMP_EQUAL("plain\nwith space\nit's\n$HOME\na\"b\n\n", r.out.c_str());
}

TEST(SiteJobs, TheSiteAndJoinCommandsCarryTheirOptions) {
  areomap::traverse::TraverseRunOptions o;
  o.out_dir = "out";
  o.products = false;
  o.truth_cross_ties = true;
  o.truth_noise_px = 0.1;
  o.cell_m = 0.05;
  const areomap::traverse::TraverseCommand c = areomap::traverse::traverseCommand("/bin/areomap-traverse", "ds", o);
  STRCMP_EQUAL("/bin/areomap-traverse ds --out out --site 2 --no-products",
               areomap::traverse::shellLine(c.site("2")).c_str());
  STRCMP_EQUAL(
      "/bin/areomap-traverse ds --out out --join --no-products --cell-m 0.05 --truth-cross-ties --noise-px 0.1",
      areomap::traverse::shellLine(c.join()).c_str());
}

TEST(SiteJobs, AFailedJobsReasonIsItsLastErrorLine) {
  const std::string dir = areomap::test::scratchDir("site-jobs-log");
  writeText(dir + "/site-2.log",
            "areomap-traverse: site 2/3: site02\nareomap-traverse: error: out/sites/site02: --out: not a folder\n"
            "slurmstepd: done\n\n");
  STRCMP_EQUAL("areomap-traverse: error: out/sites/site02: --out: not a folder",
               areomap::traverse::reasonFromLog(dir + "/site-2.log").c_str());
  STRCMP_EQUAL("", areomap::traverse::reasonFromLog(dir + "/none.log").c_str());
}
