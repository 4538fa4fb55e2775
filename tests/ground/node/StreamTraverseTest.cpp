// The traverse over the LCM stream: areomap-pack of a traverse (each site's announcement,
// then its pairs and end marker, in driving order), and areomap-ground --traverse on that log replayed from
// file: each site's pass in OUT/sites/<id>, then the traverse steps of areomap-traverse (poses.csv, the
// merged dem.tif, report.json with traverse.sites) and the same figures as areomap-traverse on the dataset
// folder; bad site announcements and unannounced pairs counted, the rest of the traverse still mapped.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "areomap/site_pose_t.hpp"
#include "areomap/site_t.hpp"
#include "areomap/stereo_pair_t.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/Traverse.hpp"
#include "ground/pack/Pack.hpp"
#include "ground/node/StreamTraverse.hpp"
#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
#include "msgs/adapters/MessageAdapters.hpp"
#include "tests/ground/traverse/ReportFiles.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// The TraverseTool group's run (ReportFiles.hpp) when CTest ran it before this group (its fixture sets
// AREOMAP_TRAVERSE_TOOL_RUN=1) and it wrote its report: "" otherwise.
std::string traverseToolRun() {
  const char* ran = std::getenv("AREOMAP_TRAVERSE_TOOL_RUN");
  const std::string out = areomap::test::scratchPath(areomap::test::kTraverseToolOut);
  if (ran == nullptr || std::string(ran) != "1" || !fs::exists(out + "/report.json")) return "";
  return out;
}

// A tiny traverse of `sites` sites of 4 pairs each (to keep every test under a minute), rendered once per
// size; of 2 sites, the TraverseTool group's dataset (the same arguments) when its run is there.
std::string traverseDataset(int sites) {
  static std::string dirs[4];
  std::string& dir = dirs[sites];
  if (dir.empty() && sites == 2 && !traverseToolRun().empty())
    dir = areomap::test::scratchPath(areomap::test::kTraverseToolDataset) + "/ds";
  if (dir.empty()) {
    // Named by process: ctest runs each group as its own process, and several groups render this size.
    dir = areomap::test::scratchDir("stream-traverse-" + std::to_string(sites) + "-" + std::to_string(::getpid())) +
          "/ds";
    const std::string args = "--preset traverse --camera tiny --pairs 4 --sites " + std::to_string(sites) +
                             " --seed 3 --leg-min-m 10 --leg-max-m 12 --out " + dir;
    if (areomap::test::runTool("areomap-sim", args) != 0) dir = "";
  }
  return dir;
}

using areomap::test::lines;
using areomap::test::readJson;

// The log of a traverse dataset (areomap-pack, with faults when `inject` is given).
std::string packLog(const std::string& ds, const std::string& name, const std::string& inject = "") {
  const std::string log = areomap::test::scratchDir(name) + "/traverse.lcm";
  const std::string args =
      ds + " --out " + log + " --interval-s 0.5" + (inject.empty() ? std::string() : " --inject " + inject);
  CHECK_EQUAL(0, areomap::test::runTool("areomap-pack", args));
  return log;
}

}  // namespace

TEST_GROUP(StreamTraversePack){};

// For each site in order: its announcement (sequence = site index, the traverse's poses and legs, the
// panorama its pairs carry, the last flag), then its pairs (sequences 0..n-1, that panorama) and its end
// marker; utime never goes back.
TEST(StreamTraversePack, SiteAnnouncementThenItsPairsInDrivingOrder) {
  const std::string ds = traverseDataset(2);
  CHECK_FALSE(ds.empty());
  const areomap::Traverse t = areomap::readTraverse(ds);
  areomap::PackOptions options;
  options.start_utime = 1'700'000'000'000'000;
  options.interval_s = 0.5;
  const std::vector<areomap::LogEvent> events = areomap::packTraverse(t, options);
  std::size_t i = 0;
  int64_t last_utime = 0;
  std::vector<std::string> panoramas;
  for (std::size_t k = 0; k < t.sites.size(); ++k) {
    const areomap::Dataset site = areomap::readDataset(t.sites[k].dir);
    CHECK_TRUE(i < events.size());
    STRCMP_EQUAL(areomap::channels::kSite, events[i].channel.c_str());
    areomap::site_t s;
    areomap::prepareSite(s);
    const char* field = "";
    CHECK_TRUE(areomap::ok(areomap::decodeSite(events[i].data.data(), events[i].data.size(), s, field)));
    CHECK_EQUAL(static_cast<int64_t>(k), s.sequence);
    STRCMP_EQUAL(t.sites[k].id.c_str(), s.site_id.c_str());
    STRCMP_EQUAL(t.name.c_str(), s.traverse.c_str());
    CHECK_EQUAL(static_cast<int>(t.sites.size()), s.sites_planned);
    CHECK_EQUAL(k + 1 == t.sites.size(), s.is_last);
    CHECK_EQUAL(t.sites[k].odometry.has_value(), s.has_odometry);
    DOUBLES_EQUAL(t.sites[k].apriori.position_m.x(), s.position_m[0], 1e-12);
    DOUBLES_EQUAL(t.sites[k].apriori.heading_rad * 180.0 / M_PI, s.heading_deg, 1e-9);
    if (s.has_odometry) {
      STRCMP_EQUAL(t.sites[k].odometry->from.c_str(), s.odometry_from.c_str());
      DOUBLES_EQUAL(t.sites[k].odometry->delta_m.y(), s.delta_m[1], 1e-12);
      DOUBLES_EQUAL(t.sites[k].odometry->sigma_m.z(), s.sigma_m[2], 1e-12);
    }
    panoramas.push_back(s.panorama);
    CHECK_TRUE(events[i].utime >= last_utime);
    last_utime = events[i].utime;
    ++i;
    for (std::size_t p = 0; p <= site.pairs.size(); ++p, ++i) {
      CHECK_TRUE(i < events.size());
      STRCMP_EQUAL(areomap::channels::kStereoPair, events[i].channel.c_str());
      areomap::stereo_pair_t m;
      CHECK_TRUE(areomap::ok(areomap::msgs::decodeMessage(events[i].data.data(), events[i].data.size(), m)));
      CHECK_EQUAL(static_cast<int64_t>(p), m.sequence);
      STRCMP_EQUAL(s.panorama.c_str(), m.panorama.c_str());
      if (p == site.pairs.size()) {
        CHECK_EQUAL(areomap::stereo_pair_t::KIND_END_OF_PANORAMA, m.kind);
      } else {
        CHECK_EQUAL(areomap::stereo_pair_t::KIND_PAIR, m.kind);
      }
      CHECK_TRUE(events[i].utime > last_utime);
      last_utime = events[i].utime;
    }
  }
  CHECK_EQUAL(events.size(), i);
  CHECK_TRUE(panoramas[0] != panoramas[1]);  // the simulator names each site's panorama apart
}

TEST_GROUP(StreamTraverseGround){};

namespace {

// areomap-ground --traverse on the packed 2-site log (file replay: no rover, so each site's ties come from
// the ground's own matcher, as in areomap-traverse's pass), with products; run once, "" when it failed.
std::string groundRun() {
  static std::string out;
  static bool ran = false;
  if (!ran) {
    ran = true;
    const std::string ds = traverseDataset(2);
    if (ds.empty()) return out;
    const std::string log = packLog(ds, "stream-traverse-log");
    out = areomap::test::scratchDir("stream-traverse-ground");
    if (areomap::test::runTool("areomap-ground",
                               "--lcm file://" + log + " --out " + out + " --traverse --truth " + ds) != 0)
      out = "";
  }
  return out;
}

// areomap-traverse on the same dataset folder, with products: the TraverseTool group's run of it when CTest
// ran that group first, else run here once; "" when it failed.
std::string referenceRun() {
  static std::string ref;
  static bool ran = false;
  if (!ran) {
    ran = true;
    const std::string ds = traverseDataset(2);
    if (ds.empty()) return ref;
    ref = traverseToolRun();
    if (!ref.empty()) return ref;
    ref = areomap::test::scratchDir("stream-traverse-reference");
    if (areomap::test::runTool("areomap-traverse", ds + " --out " + ref + " --quiet") != 0) ref = "";
  }
  return ref;
}

}  // namespace

// (CppUTest runs a file's tests last to first: this one after the two runs below, each a test of its own.)
// The same traverse from the dataset folder (areomap-traverse): the same distance and a-priori error (the
// odometry the announcements carry), the same poses within their sigmas, and each site's adjustment and the
// merged DEM to the same figures (the stream's images are JPEG-decoded, the files' PNG: the ties differ
// slightly).
TEST(StreamTraverseGround, SameFiguresAsTheTraverseTool) {
  const std::string out = groundRun(), ref = referenceRun();
  CHECK_FALSE(out.empty() || ref.empty());
  const json r = readJson(out + "/report.json");
  const json& t = r["traverse"];
  const json q = readJson(ref + "/report.json");
  const json& u = q["traverse"];
  std::printf(
      "\n  stream vs files: distance %.3f / %.3f m, position error a priori %.4f / %.4f m, after %.4f / "
      "%.4f m, method 1 %.4f / %.4f px, DEM RMSE %.4f / %.4f m\n",
      t["distance_m"].get<double>(), u["distance_m"].get<double>(),
      t["position_error_apriori_m"].get<double>(), u["position_error_apriori_m"].get<double>(),
      t["position_error_m"].get<double>(), u["position_error_m"].get<double>(), r["method1_px"].get<double>(),
      q["method1_px"].get<double>(), r["truth"]["dem_rmse_m"].get<double>(),
      q["truth"]["dem_rmse_m"].get<double>());
  DOUBLES_EQUAL(u["distance_m"].get<double>(), t["distance_m"].get<double>(), 1e-9);
  DOUBLES_EQUAL(u["position_error_apriori_m"].get<double>(), t["position_error_apriori_m"].get<double>(),
                1e-9);
  // On the odometry alone (the pair untied in both) the poses are the announcements', to the bit; placed by
  // cross-site ties, each run's ties come from its own images, so the poses agree within their sigmas.
  const bool odometry = t["site"][1]["source"] == "odometry" && u["site"][1]["source"] == "odometry";
  CHECK_EQUAL(u["site"][1]["source"].get<std::string>(), t["site"][1]["source"].get<std::string>());
  for (int k = 0; k < 2; ++k) {
    for (int c = 0; c < 3; ++c) {
      const double sigma = u["site"][k]["sigma_m"][c].get<double>();
      DOUBLES_EQUAL(u["site"][k]["position_m"][c].get<double>(), t["site"][k]["position_m"][c].get<double>(),
                    odometry ? 1e-9 : sigma);
      if (odometry) DOUBLES_EQUAL(sigma, t["site"][k]["sigma_m"][c].get<double>(), 1e-9);
    }
  }
  if (odometry) DOUBLES_EQUAL(u["position_error_m"].get<double>(), t["position_error_m"].get<double>(), 1e-9);
  DOUBLES_EQUAL(q["method1_px"].get<double>(), r["method1_px"].get<double>(), 0.02);
  DOUBLES_EQUAL(q["truth"]["dem_rmse_m"].get<double>(), r["truth"]["dem_rmse_m"].get<double>(), 0.01);
}

// areomap-traverse on the dataset folder, the reference of the comparison above.
TEST(StreamTraverseGround, TheTraverseToolOnTheFolder) {
  const std::string ref = referenceRun();
  CHECK_FALSE(ref.empty());
  CHECK_TRUE(fs::exists(ref + "/dem.tif") && fs::exists(ref + "/poses.csv"));
}

// Both sites in OUT/sites/<id> (with the received images as a dataset, stream/), poses.csv, the merged
// dem.tif / dem_sigma.tif / ortho.tif, the sites' models in the traverse frame, traverse.json and
// report.json with traverse.sites and the stream's counts.
TEST(StreamTraverseGround, FileReplayMapsEverySiteAndTheTraverse) {
  const std::string out = groundRun();
  CHECK_FALSE(out.empty());
  CHECK_EQUAL(3, lines(out + "/poses.csv"));  // header + 2 sites
  CHECK_TRUE(fs::exists(out + "/dem.tif") && fs::exists(out + "/ortho.tif") &&
             fs::exists(out + "/dem_sigma.tif"));
  CHECK_TRUE(fs::exists(out + "/sites/site01/report.json") && fs::exists(out + "/sites/site02/dem.tif"));
  CHECK_TRUE(fs::exists(out + "/sites/site02/stream/panorama.json") && fs::exists(out + "/models/site02"));
  const areomap::Traverse written = areomap::readTraverse(out);  // the announced sites, as a traverse folder
  CHECK_EQUAL(2u, written.sites.size());
  CHECK_TRUE(written.sites[1].odometry.has_value());
  const json r = readJson(out + "/report.json");
  CHECK_FALSE(r.is_discarded());
  const json& t = r["traverse"];
  CHECK_EQUAL(2, t["sites"].get<int>());
  for (const json& s : t["site"]) CHECK_TRUE(s["mapped"].get<bool>());
  CHECK_EQUAL(2, r["stream"]["sites_announced"].get<int>());
  CHECK_TRUE(r["stream"]["rejected"].empty());
  CHECK_TRUE(r["truth"]["dem_rmse_m"].get<double>() < 0.2);
  // The received sites are matched as areomap-traverse matches them: the one pair's verdict is reported.
  CHECK_EQUAL(std::string("matched"), t["cross_site_ties_source"].get<std::string>());
  CHECK_EQUAL(1u, t["site_pairs"].size());
  CHECK_TRUE(fs::exists(out + "/cross_ties.json"));
  // Usage: the cross-site options go with --traverse, one at a time.
  CHECK_EQUAL(2, areomap::test::runTool("areomap-ground",
                                        "--lcm file:///nonexistent --out " + out + "-usage --no-cross-ties"));
  CHECK_EQUAL(2, areomap::test::runTool("areomap-ground",
                                        "--lcm file:///nonexistent --out " + out +
                                            "-usage --traverse --no-cross-ties --truth-cross-ties"));
}

// Faults: site01 announced twice (site_duplicate), site02's announcement truncated (site_truncated; its
// pairs and marker then name a panorama no site announced: pair_unannounced_panorama), the rest mapped:
// site01 and site03, site03's leg recomposed from the a-priori poses with a warning.
TEST(StreamTraverseGround, BadSiteAnnouncementsCountedTheRestMapped) {
  const std::string ds = traverseDataset(3);
  CHECK_FALSE(ds.empty());
  const std::string log = packLog(ds, "stream-traverse-faults", "dup-site:0,truncate-site:2");
  const std::string out = areomap::test::scratchDir("stream-traverse-faults-out");
  CHECK_EQUAL(0, areomap::test::runTool("areomap-ground", "--lcm file://" + log + " --out " + out +
                                                              " --traverse --no-products --truth " + ds));
  const json r = readJson(out + "/report.json");
  CHECK_FALSE(r.is_discarded());
  const json& st = r["stream"];
  std::printf("\n  stream: %s\n", st.dump().c_str());
  CHECK_EQUAL(2, st["sites_announced"].get<int>());
  CHECK_EQUAL(1, st["rejected"]["site_duplicate"].get<int>());
  CHECK_EQUAL(1, st["rejected"]["site_truncated"].get<int>());
  const areomap::Dataset site02 = areomap::readDataset(ds + "/sites/site02");
  CHECK_EQUAL(static_cast<int>(site02.pairs.size()) + 1,
              st["rejected"]["pair_unannounced_panorama"].get<int>());
  const json& t = r["traverse"];
  CHECK_EQUAL(2, t["sites"].get<int>());
  STRCMP_EQUAL("site01", t["site"][0]["id"].get<std::string>().c_str());
  STRCMP_EQUAL("site03", t["site"][1]["id"].get<std::string>().c_str());
  for (const json& s : t["site"]) CHECK_TRUE(s["mapped"].get<bool>());
  CHECK_EQUAL(3, lines(out + "/poses.csv"));
  bool recomposed = false;
  for (const json& w : r["warnings"])
    recomposed =
        recomposed || w.get<std::string>().find("site02, which was not announced") != std::string::npos;
  CHECK_TRUE(recomposed);
  CHECK_FALSE(fs::exists(out + "/sites/site02"));
}

// A pair whose panorama no site announced (site02's announcement dropped): counted, and site01 still
// mapped; the ground exits 0.
TEST(StreamTraverseGround, PairOfAnUnannouncedPanoramaCounted) {
  const std::string ds = traverseDataset(2);
  CHECK_FALSE(ds.empty());
  const std::string log = packLog(ds, "stream-traverse-drop", "drop-site:1");
  const std::string out = areomap::test::scratchDir("stream-traverse-drop-out");
  CHECK_EQUAL(0, areomap::test::runTool("areomap-ground", "--lcm file://" + log + " --out " + out +
                                                              " --traverse --no-products"));
  const json r = readJson(out + "/report.json");
  CHECK_FALSE(r.is_discarded());
  const areomap::Dataset site02 = areomap::readDataset(ds + "/sites/site02");
  CHECK_EQUAL(static_cast<int>(site02.pairs.size()) + 1,
              r["stream"]["rejected"]["pair_unannounced_panorama"].get<int>());
  CHECK_EQUAL(1, r["traverse"]["sites"].get<int>());
  CHECK_TRUE(r["traverse"]["site"][0]["mapped"].get<bool>());
  bool planned = false;
  for (const json& w : r["warnings"])
    planned = planned || w.get<std::string>().find("plans 2 sites") != std::string::npos;
  CHECK_TRUE(planned);
}

TEST_GROUP(StreamTraverseAnnouncements){};

namespace {

// The announcement of site k of a hand-made 3-site traverse (what areomap-pack sends for it).
areomap::site_t announcement(int k) {
  static const double position[3][3] = {{0, 0, 0}, {10.0, 2.0, 0.1}, {18.0, 9.0, 0.3}};
  static const double heading[3] = {0.0, 20.0, 50.0};
  areomap::site_t s{};
  s.sequence = k;
  s.traverse = "hand";
  s.site_id = "site0" + std::to_string(k + 1);
  s.site_index = k;
  s.sites_planned = 3;
  s.panorama = "hand-" + s.site_id;
  for (int c = 0; c < 3; ++c) s.position_m[c] = position[k][c];
  s.heading_deg = heading[k];
  s.has_odometry = k > 0;
  if (k > 0) {
    s.odometry_from = "site0" + std::to_string(k);
    s.delta_m[0] = 9.0;  // not used where the chain is whole: the leg is taken as announced
    s.delta_heading_deg = heading[k] - heading[k - 1];
    s.distance_m = 10.0;
    s.sigma_m[0] = s.sigma_m[1] = 0.5;
    s.sigma_m[2] = 0.1;
    s.sigma_heading_deg = 2.0;
  }
  s.is_last = k == 2;
  return s;
}

}  // namespace

// The traverse the announcements describe: the sites in index order (whatever the arrival order), each leg as
// announced; where the site before was not announced, the leg from the previous announced site is the
// relative a-priori pose (so the chained poses are the announced ones), sigmas x sqrt(2) and distance x 2
// over the two legs it spans, with a warning.
TEST(StreamTraverseAnnouncements, TraverseRebuiltAndABrokenChainBridged) {
  std::vector<std::string> warnings;
  areomap::site_t stop = announcement(1);  // the middle one a traversing stop: its kind comes through
  stop.kind = areomap::site_t::KIND_STOP;
  const areomap::Traverse whole =
      areomap::traverse::traverseFromAnnouncements({announcement(2), announcement(0), stop}, "/x", warnings);
  CHECK_EQUAL(3u, whole.sites.size());
  CHECK_TRUE(whole.sites[1].kind == areomap::SiteKind::kStop);
  CHECK_TRUE(whole.sites[2].kind == areomap::SiteKind::kPanorama);
  CHECK_TRUE(warnings.empty());
  STRCMP_EQUAL("site02", whole.sites[1].id.c_str());
  STRCMP_EQUAL("sites/site02/stream", whole.sites[1].path.c_str());
  DOUBLES_EQUAL(9.0, whole.sites[2].odometry->delta_m.x(), 0.0);
  DOUBLES_EQUAL(30.0 * M_PI / 180.0, whole.sites[2].odometry->delta_heading_rad, 1e-12);
  DOUBLES_EQUAL(20.0, whole.distanceDrivenM(), 1e-12);

  const areomap::Traverse bridged =
      areomap::traverse::traverseFromAnnouncements({announcement(0), announcement(2)}, "/x", warnings);
  CHECK_EQUAL(2u, bridged.sites.size());
  CHECK_EQUAL(1u, warnings.size());
  CHECK_TRUE(warnings[0].find("site02, which was not announced") != std::string::npos);
  const areomap::OdometryLeg& leg = *bridged.sites[1].odometry;
  STRCMP_EQUAL("site01", leg.from.c_str());
  // Site 1 is the identity: the leg is site 3's a-priori position and heading.
  DOUBLES_EQUAL(18.0, leg.delta_m.x(), 1e-12);
  DOUBLES_EQUAL(9.0, leg.delta_m.y(), 1e-12);
  DOUBLES_EQUAL(0.3, leg.delta_m.z(), 1e-12);
  DOUBLES_EQUAL(50.0 * M_PI / 180.0, leg.delta_heading_rad, 1e-12);
  DOUBLES_EQUAL(0.5 * std::sqrt(2.0), leg.sigma_m.x(), 1e-12);
  DOUBLES_EQUAL(2.0 * std::sqrt(2.0) * M_PI / 180.0, leg.sigma_heading_rad, 1e-12);
  DOUBLES_EQUAL(20.0, leg.distance_m, 1e-12);
}

// The rover's AREOMAP_SITE_POSE messages as poses.csv rows (traverse order, the sites it published; the
// heading's variance the rotation's about the vertical) and their comparison with the ground's poses and the
// truth, checked against figures worked out by hand.
TEST(StreamTraverseAnnouncements, RoverPosesAgainstTheGroundsAndTheTruth) {
  areomap::Traverse t;
  for (const char* id : {"site01", "site02", "site03"}) {
    areomap::TraverseSite s;
    s.id = id;
    t.sites.push_back(s);
  }
  std::map<std::string, areomap::site_pose_t> published;
  areomap::site_pose_t first{}, third{};
  first.site_id = "site01";
  first.status = areomap::site_pose_t::STATUS_DATUM;
  first.position_m[1] = 3.0;  // where the ground and the truth put it
  third.site_id = "site03";
  third.status = areomap::site_pose_t::STATUS_TIED;
  third.position_m[0] = 20.0;
  third.position_m[1] = 3.0;
  third.heading_deg = 30.0;
  third.distance_m = 20.0;
  third.covariance[0] = 0.04;        // x
  third.covariance[6 * 5 + 5] = 1e-4;  // rotation about the vertical
  third.covariance[5] = 2e-3;        // x with it
  published["site03"] = third;
  published["site01"] = first;
  const areomap::traverse::SitePoseSolution rover = areomap::traverse::roverPoseSolution(t, published);
  CHECK_EQUAL(2u, rover.sites.size());
  STRCMP_EQUAL("site03", rover.sites[1].id.c_str());
  CHECK_TRUE(rover.sites[0].source == areomap::traverse::PoseSource::kFirstSite);
  CHECK_TRUE(rover.sites[1].source == areomap::traverse::PoseSource::kCrossSiteTies);
  DOUBLES_EQUAL(30.0 * M_PI / 180.0, rover.sites[1].pose.heading_rad, 1e-12);
  DOUBLES_EQUAL(0.04, rover.sites[1].covariance(0, 0), 0.0);
  DOUBLES_EQUAL(1e-4, rover.sites[1].covariance(3, 3), 0.0);
  DOUBLES_EQUAL(2e-3, rover.sites[1].covariance(0, 3), 0.0);

  areomap::traverse::SitePoseSolution ground;
  areomap::TraverseTruth truth;
  const double xs[3] = {0.0, 10.0, 20.3}, distance[3] = {0.0, 10.0, 20.0};
  for (int k = 0; k < 3; ++k) {
    areomap::traverse::SitePoseEstimate e;
    e.id = t.sites[static_cast<std::size_t>(k)].id;
    e.pose.position_m = Eigen::Vector3d(xs[k], 3.0, 0.0);
    e.distance_m = distance[k];
    ground.sites.push_back(e);
    areomap::SitePose p;
    p.position_m = Eigen::Vector3d(10.0 * k, 3.0, 0.0);
    truth.ids.push_back(e.id);
    truth.poses.push_back(p);
  }
  const areomap::traverse::RoverPoseComparison c = areomap::traverse::compareRoverPoses(ground, rover, truth);
  CHECK_EQUAL(2, c.sites);
  CHECK_EQUAL(1u, c.missing.size());
  DOUBLES_EQUAL(0.3, c.vs_ground_m[1], 1e-12);
  DOUBLES_EQUAL(0.3 / std::sqrt(2.0), c.vs_ground_rms_m, 1e-12);
  DOUBLES_EQUAL(0.0, c.error_m, 1e-12);               // the rover's site 3 is the truth
  DOUBLES_EQUAL(0.3 / std::sqrt(2.0), c.ground_error_m, 1e-12);  // over sites 1 and 3
  DOUBLES_EQUAL(1.5, c.ground_error_pct, 1e-9);       // 0.3 m of 20 m, the only site with a distance
}
