#include <cmath>
#include <filesystem>
#include <string>

#include "ground/dataset/Traverse.hpp"
#include "tests/ground/dataset/TextFiles.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using areomap::test::contains;
using areomap::test::writeText;

namespace {

// A valid traverse.json of two sites; `replace` swaps one piece of it for another.
std::string traverseJson(const std::string& from = "", const std::string& to = "") {
  std::string json = R"({
  "version": 1, "name": "two",
  "odometry": {"drift_fraction": 0.05, "vertical_drift_fraction": 0.01, "heading_sigma_deg": 2.0},
  "sites": [
    {"id": "site01", "path": "sites/site01", "apriori": {"position_m": [0, 0, 0], "heading_deg": 0}},
    {"id": "site02", "path": "sites/site02", "apriori": {"position_m": [10, 5, -0.2], "heading_deg": 30},
     "odometry": {"from": "site01", "delta_m": [10, 5, -0.2], "delta_heading_deg": 30, "distance_m": 11.2,
                  "sigma_m": [0.56, 0.56, 0.112], "sigma_heading_deg": 2.0}}
  ]
})";
  if (!from.empty()) {
    const std::size_t at = json.find(from);
    CHECK_TEXT(at != std::string::npos, from.c_str());
    json.replace(at, from.size(), to);
  }
  return json;
}

// Reads a traverse.json with the given text and returns the error message ("" when it reads).
std::string readError(const std::string& dir, const std::string& json) {
  writeText(dir + "/traverse.json", json);
  try {
    (void)readTraverse(dir);
  } catch (const DatasetError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_GROUP(Traverse){};

TEST(Traverse, ReadsEveryFieldAndRoundTrips) {
  const std::string dir = test::scratchDir("traverse-read");
  writeText(dir + "/traverse.json", traverseJson());
  const Traverse t = readTraverse(dir);
  CHECK_EQUAL(2, static_cast<int>(t.sites.size()));
  STRCMP_EQUAL("two", t.name.c_str());
  STRCMP_EQUAL("site02", t.sites[1].id.c_str());
  CHECK(contains(t.sites[1].dir, "sites/site02"));
  CHECK(!t.sites[0].odometry.has_value());
  const OdometryLeg& leg = *t.sites[1].odometry;
  STRCMP_EQUAL("site01", leg.from.c_str());
  DOUBLES_EQUAL(30.0 * M_PI / 180.0, leg.delta_heading_rad, 1e-15);
  DOUBLES_EQUAL(0.112, leg.sigma_m.z(), 1e-15);
  DOUBLES_EQUAL(11.2, t.distanceDrivenM(), 1e-12);
  CHECK_EQUAL(1, t.indexOf("site02"));
  CHECK_EQUAL(-1, t.indexOf("site03"));
  // The file itself may be named, too.
  CHECK_EQUAL(2, static_cast<int>(readTraverse(dir + "/traverse.json").sites.size()));
  // Without "kind" a site is a panorama; a traversing stop says so, and keeps it through a write.
  CHECK(t.sites[1].kind == SiteKind::kPanorama);
  writeText(dir + "/traverse.json",
            traverseJson("\"id\": \"site02\",", "\"id\": \"site02\", \"kind\": \"stop\","));
  const Traverse with_stop = readTraverse(dir);
  CHECK(with_stop.sites[1].kind == SiteKind::kStop);
  const std::string stop_copy = test::scratchDir("traverse-write-stop");
  writeTraverse(with_stop, stop_copy);
  CHECK(readTraverse(stop_copy).sites[1].kind == SiteKind::kStop);
  CHECK(readTraverse(stop_copy).sites[0].kind == SiteKind::kPanorama);

  const std::string copy = test::scratchDir("traverse-write");
  writeTraverse(t, copy);
  const Traverse back = readTraverse(copy);
  CHECK(back.sites[1].apriori.position_m == t.sites[1].apriori.position_m);
  DOUBLES_EQUAL(t.sites[1].apriori.heading_rad, back.sites[1].apriori.heading_rad, 1e-15);
  DOUBLES_EQUAL(t.heading_sigma_rad, back.heading_sigma_rad, 1e-15);

  // A site pose maps site points into the traverse frame and back; heading 90 degrees turns north into east.
  SitePose pose;
  pose.heading_rad = M_PI / 2.0;
  pose.position_m = Eigen::Vector3d(1.0, 2.0, 3.0);
  CHECK((pose.toTraverse(Eigen::Vector3d(1.0, 0.0, 0.0)) - Eigen::Vector3d(1.0, 3.0, 3.0)).norm() < 1e-12);
  CHECK((pose.toSite(pose.toTraverse(Eigen::Vector3d(0.3, -4.0, 0.5))) - Eigen::Vector3d(0.3, -4.0, 0.5))
            .norm() < 1e-12);
}

TEST(Traverse, EverySiteFolderMustHoldADataset) {
  const std::string dir = test::scratchDir("traverse-sites");
  writeText(dir + "/traverse.json", traverseJson());
  const Traverse t = readTraverse(dir);
  std::filesystem::create_directories(dir + "/sites/site01");
  std::filesystem::create_directories(dir + "/sites/site02");
  writeText(dir + "/sites/site01/panorama.json", "{}");
  try {
    checkTraverseSites(t);
    FAIL("a traverse without site02's dataset passed");
  } catch (const DatasetError& e) {
    CHECK_TEXT(contains(e.what(), "traverse.json: sites[1].path: 'sites/site02' holds no panorama.json"),
               e.what());
  }
  writeText(dir + "/sites/site02/panorama.json", "{}");
  checkTraverseSites(t);
}

TEST(Traverse, TruthRoundTripsAndMustNameTheSameSites) {
  const std::string dir = test::scratchDir("traverse-truth");
  writeText(dir + "/traverse.json", traverseJson());
  const Traverse t = readTraverse(dir);
  CHECK(!readTraverseTruth(dir, t).has_value());
  TraverseTruth truth;
  truth.ids = {"site01", "site02"};
  truth.poses.resize(2);
  truth.poses[1].position_m = Eigen::Vector3d(9.5, 5.5, -0.25);
  truth.poses[1].heading_rad = 0.5;
  writeTraverseTruth(truth, dir);
  const std::optional<TraverseTruth> back = readTraverseTruth(dir, t);
  CHECK(back.has_value());
  CHECK(back->poses[1].position_m == truth.poses[1].position_m);
  truth.ids = {"site01", "other"};
  writeTraverseTruth(truth, dir);
  try {
    (void)readTraverseTruth(dir, t);
    FAIL("a truth of other sites was read");
  } catch (const DatasetError& e) {
    CHECK(contains(e.what(), "truth/traverse.json: sites[1].id: 'other'"));
  }
}

TEST(Traverse, BrokenFilesAreRejectedNamingTheField) {
  const std::string dir = test::scratchDir("traverse-broken");
  const struct {
    std::string from, to, expected;
  } cases[] = {
      {"\"version\": 1", "\"version\": 2", "traverse.json: version: 2 is not supported"},
      {"\"version\": 1,", "", "traverse.json: version: missing"},
      {"\"drift_fraction\": 0.05", "\"drift_fraction\": -1", "odometry.drift_fraction: must be positive"},
      {", \"heading_sigma_deg\": 2.0}", "}", "odometry.heading_sigma_deg: missing"},
      {"\"id\": \"site02\"", "\"id\": \"site01\"", "sites[1].id: duplicate id 'site01'"},
      {"\"id\": \"site02\"", "\"id\": \"site 2\"", "sites[1].id: 'site 2': only letters"},
      {"\"path\": \"sites/site02\"", "\"path\": \"../site02\"", "sites[1].path: '..' components"},
      {"\"path\": \"sites/site02\"", "\"path\": \"sites/site01\"", "sites[1].path: 'sites/site01' is used"},
      {"\"position_m\": [0, 0, 0]", "\"position_m\": [1, 0, 0]", "sites[0].apriori: the first site's pose"},
      {"\"heading_deg\": 30}", "\"heading_deg\": \"north\"}",
       "sites[1].apriori.heading_deg: expected a number"},
      {"\"from\": \"site01\"", "\"from\": \"site07\"", "sites[1].odometry.from: 'site07'"},
      {"\"sigma_m\": [0.56, 0.56, 0.112]", "\"sigma_m\": [0.56, 0, 0.112]",
       "sites[1].odometry.sigma_m[1]: must be"},
      {"\"distance_m\": 11.2,", "", "sites[1].odometry.distance_m: missing"},
      {"\"delta_m\": [10, 5, -0.2]", "\"delta_m\": [10, 5]", "sites[1].odometry.delta_m: expected an array"},
      {"\"id\": \"site02\",", "\"id\": \"site02\", \"kind\": \"drive\",",
       "sites[1].kind: 'drive': expected \"panorama\" or \"stop\""},
  };
  for (const auto& c : cases) {
    const std::string error = readError(dir, traverseJson(c.from, c.to));
    CHECK_TEXT(contains(error, c.expected), (c.expected + " <- got: " + error).c_str());
    CHECK_TEXT(contains(error, dir), error.c_str());
  }
  // A site without odometry after the first, a first site with it, no sites, not JSON, no file.
  const std::string no_leg = readError(dir, traverseJson(R"(,
     "odometry": {"from": "site01", "delta_m": [10, 5, -0.2], "delta_heading_deg": 30, "distance_m": 11.2,
                  "sigma_m": [0.56, 0.56, 0.112], "sigma_heading_deg": 2.0}})",
                                                         "}"));
  CHECK_TEXT(contains(no_leg, "sites[1].odometry: missing"), no_leg.c_str());
  CHECK(contains(readError(dir, R"({"version": 1, "odometry": {"drift_fraction": 0.05,
      "vertical_drift_fraction": 0.01, "heading_sigma_deg": 2}, "sites": []})"),
                 "sites: empty"));
  CHECK(contains(readError(dir, "{\"version\": 1, "), "not valid JSON"));
  try {
    (void)readTraverse(dir + "/nowhere");
    FAIL("a missing traverse.json was read");
  } catch (const DatasetError& e) {
    CHECK(contains(e.what(), "nowhere/traverse.json: cannot open"));
  }
}
