#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "areomap/eo_solution_t.hpp"
#include "areomap/rover_status_t.hpp"
#include "areomap/stereo_pair_t.hpp"
#include "firmware_core/adjust/FastAdjuster.hpp"
#include "firmware_core/node/RoverNode.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/pack/Pack.hpp"
#include "ground/ties/TieAdjust.hpp"
#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "platform/posix/ArenaJpegDecoder.hpp"
#include "platform/posix/LcmLogReplay.hpp"
#include "platform/posix/LcmTransport.hpp"
#include "platform/posix/PosixClock.hpp"
#include "platform/posix/TurboJpegCodec.hpp"
#include "platform/stub/MemoryTransport.hpp"
#include "tests/ground/pack/TinyStream.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

// CppUTest prints a Status by its name.
SimpleString StringFrom(areomap::Status status) { return SimpleString(areomap::statusName(status)); }

namespace {

// The tiny simulated panorama (8 pairs), made once per process.
const std::string& tinyDataset() {
  static const std::string dir = test::makeTinyDataset("pack-tiny");
  CHECK(!dir.empty());
  return dir;
}

const std::vector<LogEvent>& tinyStream() {
  static const std::vector<LogEvent> events = test::packedStream(tinyDataset());
  return events;
}

// Statically allocated once (~45 MiB), as on the rover.
RoverNode& node() {
  static auto* n = new RoverNode();
  return *n;
}
uint8_t g_arena[platform::ArenaJpegDecoder::kArenaBytes];

struct Captured {
  eo_solution_t last_eo;
  bool have_final = false;
  rover_status_t last_status;
  int statuses = 0;
  int tiepoints = 0;
  int dems = 0;
};

void onEo(void* ctx, const char*, const uint8_t* data, std::size_t size) {
  auto* c = static_cast<Captured*>(ctx);
  eo_solution_t m;
  if (ok(msgs::decodeMessage(data, size, m)) && m.is_final) {
    c->last_eo = m;
    c->have_final = true;
  }
}
void onStatus(void* ctx, const char*, const uint8_t* data, std::size_t size) {
  auto* c = static_cast<Captured*>(ctx);
  rover_status_t m;
  if (ok(msgs::decodeMessage(data, size, m))) {
    c->last_status = m;
    c->statuses += 1;
  }
}
void onCount(void* ctx, const char*, const uint8_t*, std::size_t) { *static_cast<int*>(ctx) += 1; }

struct PairFeeder {
  uint64_t pipeline_allocs = 0;
};
void onPair(void* ctx, const char*, const uint8_t* data, std::size_t size) {
  auto* f = static_cast<PairFeeder*>(ctx);
  const uint64_t before = heapAllocationCountThisThread();
  node().handleStereoPair(data, size);
  f->pipeline_allocs += heapAllocationCountThisThread() - before;
}

// The rover's outbox (as in areomap-rover): publications are copied into a heap-free queue and forwarded to
// the captures after each message, so that only the pipeline's own work is counted.
uint8_t g_outbox[4 * 1024 * 1024];

// Runs the events through memq:// into the rover node (one process, one thread).
Captured runThroughMemq(const std::vector<LogEvent>& events, uint64_t& pipeline_allocs) {
  platform::LcmTransport lcm;
  CHECK_EQUAL(Status::kOk, lcm.open("memq://"));
  platform::MemoryTransport outbox(g_outbox, sizeof(g_outbox));
  platform::ArenaJpegDecoder jpeg(g_arena, sizeof(g_arena));
  CHECK_EQUAL(Status::kOk, jpeg.open());
  platform::PosixClock clock;
  RoverOptions options;
  options.log_to_stderr = false;
  node().start(outbox, jpeg, clock, options);
  static Captured captured;
  captured = Captured{};
  PairFeeder feeder;
  CHECK_EQUAL(Status::kOk, lcm.subscribe(channels::kStereoPair, onPair, &feeder));
  CHECK_EQUAL(Status::kOk, outbox.subscribe(channels::kEoSolution, onEo, &captured));
  CHECK_EQUAL(Status::kOk, outbox.subscribe(channels::kRoverStatus, onStatus, &captured));
  CHECK_EQUAL(Status::kOk, outbox.subscribe(channels::kTiePoints, onCount, &captured.tiepoints));
  CHECK_EQUAL(Status::kOk, outbox.subscribe(channels::kCoarseDem, onCount, &captured.dems));
  for (const LogEvent& e : events) {
    CHECK_EQUAL(Status::kOk, lcm.publish(e.channel.c_str(), e.data.data(), e.data.size()));
    for (int k = 0; k < 100 && lcm.handle(0) == Status::kOk; ++k) {
    }
    for (int k = 0; k < 100 && outbox.handle(0) == Status::kOk; ++k) {
    }
  }
  CHECK_EQUAL(0u, outbox.refused());
  pipeline_allocs = feeder.pipeline_allocs;
  return captured;
}

// The offline reference on the same JPEG-decoded pixels: the matcher and adapter pair by pair as
// areomap-ties does, the rig from panorama.json or estimated (setRigConstraints), one fast adjustment.
struct Offline {
  std::unique_ptr<PanoramaMatcher> matcher = std::make_unique<PanoramaMatcher>();
  std::unique_ptr<NetworkAdapter> adapter = std::make_unique<NetworkAdapter>();
  std::unique_ptr<Network> net = std::make_unique<Network>();
};

void runOffline(const Dataset& dataset, const std::vector<LogEvent>& events, Offline& off) {
  platform::TurboJpegCodec codec;
  CHECK_EQUAL(Status::kOk, codec.open());
  off.matcher->reset();
  off.matcher->planForPairs(kMaxPairs);  // as the rover (it does not know the pair count in advance)
  off.adapter->reset();
  off.net->clear();
  std::vector<int> sols;
  std::vector<uint8_t> pix[2] = {std::vector<uint8_t>(kMaxImagePixels), std::vector<uint8_t>(kMaxImagePixels)};
  for (const LogEvent& e : events) {
    stereo_pair_t p;
    CHECK_EQUAL(Status::kOk, msgs::decodeMessage(e.data.data(), e.data.size(), p));
    if (p.kind != stereo_pair_t::KIND_PAIR) continue;
    CameraModel models[2];
    const char* field = "";
    ImageView views[2];
    const stereo_image_t* sides[2] = {&p.left, &p.right};
    for (int s = 0; s < (p.has_right ? 2 : 1); ++s) {
      CHECK_EQUAL(Status::kOk, toCameraModel(sides[s]->model, models[s], field));
      int32_t w = 0, h = 0;
      CHECK_EQUAL(Status::kOk, codec.decodeGray(sides[s]->jpeg.data(), sides[s]->jpeg.size(), pix[s].data(),
                                                pix[s].size(), w, h));
      views[s] = ImageView{pix[s].data(), w, h, w};
    }
    PairTieReport report;
    (void)off.matcher->addPair(views[0], p.has_right ? &views[1] : nullptr, models[0],
                               p.has_right ? &models[1] : nullptr, report);
    int sol = -1;
    for (std::size_t i = 0; i < sols.size(); ++i)
      if (sols[i] == p.sol) sol = static_cast<int>(i);
    if (sol < 0) {
      sol = static_cast<int>(sols.size());
      sols.push_back(p.sol);
    }
    int32_t failed = 0;
    CHECK_EQUAL(Status::kOk, off.adapter->syncPair(*off.matcher, sol, p.tier, models[0],
                                                   p.has_right ? &models[1] : nullptr, *off.net, failed));
  }
  std::vector<std::string> notes;
  setRigConstraints(dataset, sols, *off.net, notes);
  const AdjustOutcome o = adjustNetwork(*off.net, FastAdjustOptions{});
  CHECK_EQUAL(Status::kOk, o.result.status);
}

// Largest pixel-equivalent EO difference between two networks with the same images.
double maxEoDifferencePx(const Network& a, const Network& b) {
  double worst = 0.0;
  for (int32_t i = 0; i < a.imageCount(); ++i) {
    const NetImage& x = a.image(i);
    const NetImage& y = b.image(i);
    worst = std::max(worst, eoPixelEquivalent(x.io.f_px, x.center_m - y.center_m, rotationAngle(x.m, y.m), 5.0));
  }
  return worst;
}

}  // namespace

TEST_GROUP(PackStream){};

// One event per pair in order, sequence numbers 0..n-1, the marker last, timestamps interval_s apart,
// decodable JPEGs of the image size, rig values equal to what setRigConstraints estimates.
TEST(PackStream, TinyStreamIsOrderedAndComplete) {
  const Dataset dataset = readDataset(tinyDataset());
  const std::vector<LogEvent>& events = tinyStream();
  CHECK_EQUAL(dataset.pairs.size() + 1, events.size());
  platform::TurboJpegCodec codec;
  CHECK_EQUAL(Status::kOk, codec.open());
  std::vector<uint8_t> pixels(kMaxImagePixels);
  for (std::size_t k = 0; k < events.size(); ++k) {
    stereo_pair_t p;
    CHECK_EQUAL(Status::kOk, msgs::decodeMessage(events[k].data.data(), events[k].data.size(), p));
    CHECK_EQUAL(static_cast<int64_t>(k), p.sequence);
    CHECK_EQUAL(1'700'000'000'000'000 + static_cast<int64_t>(k) * 3'000'000, p.utime);
    if (k == dataset.pairs.size()) {
      CHECK_EQUAL(stereo_pair_t::KIND_END_OF_PANORAMA, p.kind);
      continue;
    }
    CHECK_EQUAL(stereo_pair_t::KIND_PAIR, p.kind);
    STRCMP_EQUAL(dataset.pairs[k].left.stem.c_str(), p.left.stem.c_str());
    int32_t w = 0, h = 0;
    CHECK_EQUAL(Status::kOk, codec.decodeGray(p.left.jpeg.data(), p.left.jpeg.size(), pixels.data(), pixels.size(), w, h));
    CHECK_EQUAL(p.left.width_px, w);
    CHECK_EQUAL(p.left.height_px, h);
    CHECK_TRUE(p.has_right == dataset.pairs[k].right.has_value());
  }
  // The log file reads back with the platform's replay (the same format lcm-logger writes).
  const std::string log = test::scratchDir("pack-log") + "/tiny.lcm";
  writeEventLog(log, events);
  std::vector<uint8_t> buffer(2 * kMaxJpegBytes + 65536);
  platform::LcmLogReplay replay(buffer.data(), buffer.size());
  CHECK_EQUAL(Status::kOk, replay.open(log.c_str()));
  std::size_t read = 0;
  while (replay.handle(0) == Status::kOk) ++read;
  CHECK_EQUAL(events.size(), read);
}

TEST_GROUP(RoverMemq){};

// The tiny panorama through memq:// in one process: every pair accepted, the final EO published, zero heap
// allocations in the pipeline across the whole panorama, and the rover's final EO equal to the offline
// adjustment of the same JPEG-decoded pixels within 0.01 px equivalent.
TEST(RoverMemq, TinyEndToEndEqualsOfflineAndZeroHeap) {
  const Dataset dataset = readDataset(tinyDataset());
  uint64_t allocs = 99;
  const Captured c = runThroughMemq(tinyStream(), allocs);
  const RoverCounters& k = node().counters();
  std::printf("rover memq tiny: %d pairs accepted of %d, final rms %.4f px, %d sweeps, %d tie-point and %d DEM "
              "messages, pipeline heap allocations %llu (heap counter %s)\n",
              k.pairs_accepted, k.pairs_seen, k.last_rms_px, k.last_sweeps, c.tiepoints, c.dems,
              static_cast<unsigned long long>(allocs), heapCounterActive() ? "on" : "off");
  CHECK_EQUAL(static_cast<int>(dataset.pairs.size()), k.pairs_accepted);
  CHECK_EQUAL(0, k.pairs_rejected);
  CHECK_TRUE(c.have_final);
  CHECK_EQUAL(2 * static_cast<int>(dataset.pairs.size()), c.last_eo.num_images);
  CHECK_EQUAL(static_cast<int>(dataset.pairs.size()), c.tiepoints);
  CHECK_EQUAL(static_cast<int>(dataset.pairs.size()), c.dems);
  CHECK_EQUAL(rover_status_t::STATE_FINISHED, c.last_status.state);
  if (heapCounterActive()) CHECK_EQUAL(0u, allocs);

  Offline off;
  runOffline(dataset, tinyStream(), off);
  CHECK_EQUAL(off.net->imageCount(), node().network().imageCount());
  const double diff = maxEoDifferencePx(node().network(), *off.net);
  std::printf("rover final EO vs offline areomap-ties --adjust path on the same pixels: max %.6f px equivalent\n", diff);
  CHECK_TRUE(diff < 0.01);
}

// A stream with injected faults: each counted under its own cause, the rest processed, no crash, and the
// final EO equal to the offline adjustment of the pairs that got through (in the order they were processed).
TEST(RoverMemq, InjectedFaultsCountedUnderTheirCauses) {
  const std::vector<LogEvent> faulty = injectFaults(
      tinyStream(), "drop:2,dup:3,swap:5,truncate:4,corrupt-jpeg:6,unknown-channel,wrong-type,oversize:7,nan-model:1");
  uint64_t allocs = 99;
  const Captured c = runThroughMemq(faulty, allocs);
  const RoverCounters& k = node().counters();
  auto cause = [&](Status s) { return k.rejected_by_cause[static_cast<int>(s)]; };
  std::printf("faults: seen %d accepted %d rejected %d; gaps %d duplicates %d reordered %d; truncated %d corrupt %d "
              "capacity %d unsupported %d not_finite %d; heap %llu; last error: %s\n",
              k.pairs_seen, k.pairs_accepted, k.pairs_rejected, k.sequence_gaps, k.duplicates, k.reordered,
              cause(Status::kTruncated), cause(Status::kCorruptData), cause(Status::kCapacityExceeded),
              cause(Status::kUnsupported), cause(Status::kNotFinite), static_cast<unsigned long long>(allocs),
              node().lastError());
  CHECK_EQUAL(2, k.sequence_gaps);   // pair 2 dropped; pair 4 truncated (its sequence cannot be read)
  CHECK_EQUAL(1, k.duplicates);      // pair 3 twice
  CHECK_EQUAL(1, k.reordered);       // 5 after 6
  CHECK_EQUAL(1, cause(Status::kTruncated));
  CHECK_EQUAL(1, cause(Status::kCorruptData));
  CHECK_EQUAL(1, cause(Status::kCapacityExceeded));
  CHECK_EQUAL(1, cause(Status::kUnsupported));
  CHECK_EQUAL(1, cause(Status::kNotFinite));
  // Pairs 0, 3, 5 processed (1 NaN model, 2 dropped, 4 truncated, 6 corrupt JPEG, 7 oversize).
  CHECK_EQUAL(3, k.pairs_accepted);
  CHECK_TRUE(c.have_final);
  CHECK_EQUAL(rover_status_t::STATE_FINISHED, c.last_status.state);
  CHECK_EQUAL(2, c.last_status.sequence_gaps);
  CHECK_EQUAL(1, c.last_status.rejected_by_cause[rover_status_t::CAUSE_NOT_FINITE]);
  if (heapCounterActive()) CHECK_EQUAL(0u, allocs);

  // The offline path on the clean messages of pairs 0, 3, 5 gives the same EO.
  std::vector<LogEvent> survivors;
  for (int seq : {0, 3, 5, 8}) survivors.push_back(tinyStream()[static_cast<std::size_t>(seq)]);
  Offline off;
  runOffline(readDataset(tinyDataset()), survivors, off);
  CHECK_EQUAL(off.net->imageCount(), node().network().imageCount());
  const double diff = maxEoDifferencePx(node().network(), *off.net);
  std::printf("faulty stream: final EO vs offline on the surviving pairs: max %.6f px equivalent, rms %.4f px\n", diff,
              c.last_eo.rms_px);
  CHECK_TRUE(diff < 0.01);
}

TEST_GROUP(RoverTool){};

// The areomap-rover binary on a file:// replay of the tiny log: exit 0; --help 0; no --lcm 2.
TEST(RoverTool, ReplaysALogAndExits) {
  const std::string dir = test::scratchDir("rover-tool");
  writeEventLog(dir + "/tiny.lcm", tinyStream());
  CHECK_EQUAL(0, test::runTool("areomap-rover", "--lcm file://" + dir + "/tiny.lcm --quiet"));
  CHECK_EQUAL(0, test::runTool("areomap-rover", "--help"));
  CHECK_EQUAL(2, test::runTool("areomap-rover", ""));
  CHECK_EQUAL(2, test::runTool("areomap-pack", tinyDataset()));
  CHECK_EQUAL(1, test::runTool("areomap-pack", dir + "/missing --out " + dir + "/x.lcm"));
}

TEST_GROUP(PackRealData){};

// Two left-only PDS3 Navcam frames of Opportunity (models from their labels): packed as single images
// (has_right false), decoded and mapped by the rover; the final adjustment runs on the inter-image ties.
TEST(PackRealData, OpportunityLeftOnlyPds3) {
  if (!test::requireSharedData("mer-opportunity-navcam-sol4087")) return;
  const std::string src = test::sharedDataDir() + "/mer-opportunity-navcam-sol4087";
  const std::string dir = test::scratchDir("pack-oppy");
  std::filesystem::create_directories(dir + "/images");
  const char* frames[] = {"1N491020376ILFCNY9P0706L0M1.IMG", "1N491020519ILFCNY9P0706L0M1.IMG"};
  for (const char* f : frames) std::filesystem::create_symlink(src + "/" + f, dir + "/images/" + f);
  std::ofstream(dir + "/panorama.json") << R"({"name": "oppy", "pairs": [
      {"left": {"image": "images/1N491020376ILFCNY9P0706L0M1.IMG"}},
      {"left": {"image": "images/1N491020519ILFCNY9P0706L0M1.IMG"}}]})";
  const std::vector<LogEvent> events = packDataset(readDataset(dir), PackOptions{});
  CHECK_EQUAL(3u, events.size());
  stereo_pair_t p;
  CHECK_EQUAL(Status::kOk, msgs::decodeMessage(events[0].data.data(), events[0].data.size(), p));
  CHECK_FALSE(p.has_right);
  CHECK_EQUAL(0, p.right.jpeg_bytes);
  CHECK_EQUAL(1024, p.left.width_px);
  CHECK_EQUAL(camera_model_t::TYPE_CAHVOR, p.left.model.type);
  CHECK_FALSE(p.gimbal_given);
  uint64_t allocs = 99;
  const Captured c = runThroughMemq(events, allocs);
  std::printf("opportunity: accepted %d of %d, final EO of %d images, rms %.3f px, pipeline heap %llu\n",
              node().counters().pairs_accepted, node().counters().pairs_seen, c.last_eo.num_images, c.last_eo.rms_px,
              static_cast<unsigned long long>(allocs));
  CHECK_EQUAL(2, node().counters().pairs_accepted);
  CHECK_TRUE(c.have_final);
  CHECK_EQUAL(2, c.last_eo.num_images);
  if (heapCounterActive()) CHECK_EQUAL(0u, allocs);
}
