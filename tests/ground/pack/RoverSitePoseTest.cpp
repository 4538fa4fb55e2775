// The rover localising itself over a small simulated traverse (the tiny camera, areomap-pack of the whole
// traverse fed to the node in one process): after each site AREOMAP_SITE_POSE for every site of its window,
// zero heap in the pipeline over all sites, and the last published pose of each site against the truth: its
// error within 3 of its published sigmas per horizontal axis, and never worse than the odometry's by more
// than a centimetre (an untied leg keeps the odometry). On this terrain the rover's 0.5 m DEMs of the tiny
// camera's ties do not register (as the ground's own products of it do not: docs/traverse.md "Limits"), so
// the legs stay the odometry's; the matcher and the adjustment of its ties are tested on synthetic scenes
// (firmware_core/match CrossSiteMatcher, firmware_core/dem CoarseDemRegistration).
// The legs are 6-8 m: the tiny camera (tilted 30 degrees down on a 1.5 m mast) sees the ground out to about
// 11 m, so neighbouring sites share ground only on such legs.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "areomap/site_pose_t.hpp"
#include "areomap/tiepoints_t.hpp"
#include "ground/dataset/Traverse.hpp"
#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
#include "platform/posix/LcmLogReplay.hpp"
#include "tests/ground/pack/RoverHarness.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

struct SitePoseCapture {
  std::map<std::string, site_pose_t> last;  // by site id
  int messages = 0;
  static void on(void* ctx, const char*, const uint8_t* data, std::size_t size) {
    auto* self = static_cast<SitePoseCapture*>(ctx);
    site_pose_t m;
    if (!ok(msgs::decodeMessage(data, size, m))) return;
    self->last[m.site_id] = m;
    self->messages += 1;
  }
};

// Counts the messages on AREOMAP_TIEPOINTS that do not decode as tiepoints_t (another message sent under
// its name).
struct ForeignTiePoints {
  int messages = 0;
  int foreign = 0;
  static void on(void* ctx, const char*, const uint8_t* data, std::size_t size) {
    auto* self = static_cast<ForeignTiePoints*>(ctx);
    self->messages += 1;
    self->foreign += ok(msgs::decodeMessage(data, size, self->scratch)) ? 0 : 1;
  }
  tiepoints_t scratch;
};

constexpr int kSites = 3;

// The small traverse, simulated once per process, and its stream.
const std::string& traverseDir() {
  static const std::string ds = [] {
    const std::string d = test::scratchDir("rover-site-poses-" + std::to_string(::getpid())) + "/ds";
    CHECK_EQUAL(0, test::runTool("areomap-sim", "--preset traverse --camera tiny --pairs 4 --sites 3 --seed 21 "
                                                "--leg-min-m 6 --leg-max-m 8 --max-turn-deg 20 --out " +
                                                    d));
    return d;
  }();
  return ds;
}

std::vector<LogEvent> traverseStream(const Traverse& traverse) {
  PackOptions options;
  options.start_utime = 1'700'000'000'000'000;
  return packTraverse(traverse, options);
}

}  // namespace

TEST_GROUP(RoverSitePoses){};

TEST(RoverSitePoses, SmallTraverseLocalisedOnBoardWithZeroHeap) {
  const std::string& ds = traverseDir();
  const int sites = kSites;
  const Traverse traverse = readTraverse(ds);
  const std::optional<TraverseTruth> truth = readTraverseTruth(ds, traverse);
  CHECK_TRUE(truth.has_value());
  const std::vector<LogEvent> events = traverseStream(traverse);
  SitePoseCapture capture;
  const uint64_t allocations = test::feedRover(events, [&](platform::MemoryTransport& outbox) {
    CHECK(ok(outbox.subscribe(channels::kSitePose, SitePoseCapture::on, &capture)));
  });
  const RoverNode& node = test::harnessRover();
  const RoverTraverseCounters& t = node.traverse().counters();
  std::printf("\nrover site poses: %d messages, %d sites adjusted, pipeline heap allocations %llu (counter %s); "
              "on-board traverse steps %.3f s per site (registration, matching, adjustment), the panorama %.3f s\n",
              capture.messages, t.sites_adjusted, static_cast<unsigned long long>(allocations),
              heapCounterActive() ? "on" : "off", node.counters().traverse_seconds / sites,
              node.counters().panorama_seconds);
  if (heapCounterActive()) CHECK_EQUAL(0u, allocations);
  CHECK_EQUAL(sites, t.sites_adjusted);
  CHECK_EQUAL(1 + 2 + 3, capture.messages);  // the window of 4 holds every site here
  double distance = 0.0, sum2_after = 0.0, sum2_apriori = 0.0;
  for (int k = 0; k < sites; ++k) {
    const std::string& id = traverse.sites[static_cast<std::size_t>(k)].id;
    CHECK_TRUE(capture.last.count(id) == 1);
    const site_pose_t& m = capture.last[id];
    const Eigen::Vector3d p(m.position_m[0], m.position_m[1], m.position_m[2]);
    const Eigen::Vector3d truth_p = truth->poses[static_cast<std::size_t>(k)].position_m;
    const Eigen::Vector3d apriori_p = traverse.sites[static_cast<std::size_t>(k)].apriori.position_m;
    distance = m.distance_m;
    std::printf("  %s: status %d, registration %d, %d tie observations, error %.3f m (a priori %.3f m), "
                "sigma %.3f %.3f m, distance %.2f m\n",
                id.c_str(), static_cast<int>(m.status), static_cast<int>(m.registration),
                static_cast<int>(m.tie_observations), (p - truth_p).norm(), (apriori_p - truth_p).norm(),
                m.sigma_position_m[0], m.sigma_position_m[1], m.distance_m);
    if (k == 0) continue;
    sum2_after += (p - truth_p).squaredNorm();
    sum2_apriori += (apriori_p - truth_p).squaredNorm();
    // The published sigma covers the error (3 sigmas per horizontal axis).
    for (int a = 0; a < 2; ++a) CHECK_TRUE(std::fabs(p[a] - truth_p[a]) <= 3.0 * m.sigma_position_m[a] + 1e-3);
    CHECK_TRUE((p - truth_p).norm() <= (apriori_p - truth_p).norm() + 0.01);
  }
  const double rms_after = std::sqrt(sum2_after / (sites - 1)), rms_apriori = std::sqrt(sum2_apriori / (sites - 1));
  std::printf("  position RMS %.3f m after, %.3f m a priori, over %.1f m driven (%.2f %% and %.2f %%)\n", rms_after,
              rms_apriori, distance, 100.0 * rms_after / distance, 100.0 * rms_apriori / distance);
}

// The areomap-rover process (its transport thread, outbox and LCM publisher, not only the node) on a file://
// replay of the traverse, publishing into a log: every site pose on AREOMAP_SITE_POSE, one per site of each
// window as in-process, and nothing else sent under another channel's name.
TEST(RoverSitePoses, TheRoverProcessPublishesThemOnTheirChannel) {
  const std::string& ds = traverseDir();
  const Traverse traverse = readTraverse(ds);
  const std::string dir = test::scratchDir("rover-site-poses-tool-" + std::to_string(::getpid()));
  writeEventLog(dir + "/traverse.lcm", traverseStream(traverse));
  CHECK_EQUAL(0, test::runTool("areomap-rover", "--lcm file://" + dir + "/traverse.lcm --publish file://" + dir +
                                                    "/out.lcm?mode=w --quiet"));
  std::vector<uint8_t> buffer(8u << 20);
  platform::LcmLogReplay replay(buffer.data(), buffer.size());
  CHECK_TRUE(ok(replay.open((dir + "/out.lcm").c_str())));
  SitePoseCapture poses;
  ForeignTiePoints ties;
  CHECK(ok(replay.subscribe(channels::kSitePose, SitePoseCapture::on, &poses)));
  CHECK(ok(replay.subscribe(channels::kTiePoints, ForeignTiePoints::on, &ties)));
  while (replay.handle(0) == Status::kOk) {
  }
  std::printf("\nareomap-rover: %d site poses, %d tie-point messages (%d foreign)\n", poses.messages, ties.messages,
              ties.foreign);
  CHECK_EQUAL(1 + 2 + 3, poses.messages);
  for (const TraverseSite& site : traverse.sites) CHECK_TRUE(poses.last.count(site.id) == 1);
  CHECK_TRUE(ties.messages > 0);
  CHECK_EQUAL(0, ties.foreign);
}
