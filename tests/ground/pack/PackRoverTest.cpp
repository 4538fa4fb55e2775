// The rover node fed the packed tiny stream through memq:// in one process
// (firmware_core/node/RoverNode.hpp): its result equals the offline ties tool with zero heap in the pipeline,
// injected faults and full capacities are counted with the panorama kept, a two-site traverse maps each site
// as alone; and two real left-only PDS3 frames packed and mapped.
#include <sys/wait.h>

#include <algorithm>
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
#include "areomap/tiepoints_t.hpp"
#include "firmware_core/adjust/FastAdjuster.hpp"
#include "firmware_core/camera/CameraConversion.hpp"
#include "firmware_core/node/RoverNode.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/Traverse.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/pack/Pack.hpp"
#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "platform/posix/ArenaJpegDecoder.hpp"
#include "platform/posix/LcmTransport.hpp"
#include "platform/posix/PosixClock.hpp"
#include "platform/posix/TurboJpegCodec.hpp"
#include "platform/stub/MemoryTransport.hpp"
#include "tests/ground/pack/TinyStream.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

// CppUTest prints a Status by its name (PackStreamTest.cpp).
SimpleString StringFrom(areomap::Status status);

namespace {

const std::string& tinyDataset() {
  CHECK(!test::tinyPackDataset().empty());
  return test::tinyPackDataset();
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
  std::vector<eo_solution_t> finals;  // every final EO (one per panorama), in order
  rover_status_t last_status;
  int statuses = 0;
  int tiepoints = 0;
  int dems = 0;
  std::vector<ImageObservation> ties;  // every AREOMAP_TIEPOINTS observation, in order (image = stem)
};

void onEo(void* ctx, const char*, const uint8_t* data, std::size_t size) {
  auto* c = static_cast<Captured*>(ctx);
  eo_solution_t m;
  if (ok(msgs::decodeMessage(data, size, m)) && m.is_final) {
    c->last_eo = m;
    c->have_final = true;
    c->finals.push_back(m);
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
void onCount(void* ctx, const char*, const uint8_t*, std::size_t) {
  *static_cast<int*>(ctx) += 1;
}
void onTies(void* ctx, const char*, const uint8_t* data, std::size_t size) {
  auto* c = static_cast<Captured*>(ctx);
  tiepoints_t m;
  if (!ok(msgs::decodeMessage(data, size, m))) return;
  c->tiepoints += 1;
  for (int32_t i = 0; i < m.num_observations; ++i) {
    ImageObservation o;
    o.point = m.point_id[static_cast<std::size_t>(i)];
    o.image = m.image_stems[static_cast<std::size_t>(m.image_index[static_cast<std::size_t>(i)])];
    o.sample_px = m.sample_px[static_cast<std::size_t>(i)];
    o.line_px = m.line_px[static_cast<std::size_t>(i)];
    o.kind = m.kind[static_cast<std::size_t>(i)] == tiepoints_t::KIND_INTRA ? "intra" : "inter";
    c->ties.push_back(o);
  }
}

struct PairFeeder {
  uint64_t pipeline_allocs = 0;
};
void onPair(void* ctx, const char*, const uint8_t* data, std::size_t size) {
  auto* f = static_cast<PairFeeder*>(ctx);
  const uint64_t before = heapAllocationCountThisThread();
  node().handleStereoPair(data, size);
  f->pipeline_allocs += heapAllocationCountThisThread() - before;
}
void onSite(void* ctx, const char*, const uint8_t* data, std::size_t size) {
  auto* f = static_cast<PairFeeder*>(ctx);
  const uint64_t before = heapAllocationCountThisThread();
  node().handleSite(data, size);
  f->pipeline_allocs += heapAllocationCountThisThread() - before;
}

// The rover's outbox (as in areomap-rover): publications are copied into a heap-free queue and forwarded to
// the captures after each message, so that only the pipeline's own work is counted.
uint8_t g_outbox[4 * 1024 * 1024];

// Runs the events through memq:// into the rover node (one process, one thread).
Captured runThroughMemq(const std::vector<LogEvent>& events, uint64_t& pipeline_allocs,
                        const RoverOptions& given = RoverOptions{}) {
  platform::LcmTransport lcm;
  CHECK_EQUAL(Status::kOk, lcm.open("memq://"));
  platform::MemoryTransport outbox(g_outbox, sizeof(g_outbox));
  platform::ArenaJpegDecoder jpeg(g_arena, sizeof(g_arena));
  CHECK_EQUAL(Status::kOk, jpeg.open());
  platform::PosixClock clock;
  RoverOptions options = given;
  options.log_to_stderr = false;
  node().start(outbox, jpeg, clock, options);
  static Captured captured;
  captured = Captured{};
  PairFeeder feeder;
  CHECK_EQUAL(Status::kOk, lcm.subscribe(channels::kStereoPair, onPair, &feeder));
  CHECK_EQUAL(Status::kOk, lcm.subscribe(channels::kSite, onSite, &feeder));
  CHECK_EQUAL(Status::kOk, outbox.subscribe(channels::kEoSolution, onEo, &captured));
  CHECK_EQUAL(Status::kOk, outbox.subscribe(channels::kRoverStatus, onStatus, &captured));
  CHECK_EQUAL(Status::kOk, outbox.subscribe(channels::kTiePoints, onTies, &captured));
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

stereo_pair_t decodePair(const LogEvent& e) {
  stereo_pair_t p;
  CHECK_EQUAL(Status::kOk, msgs::decodeMessage(e.data.data(), e.data.size(), p));
  return p;
}

LogEvent encodePair(const stereo_pair_t& p, int64_t utime) {
  LogEvent e{channels::kStereoPair, utime,
             std::vector<uint8_t>(static_cast<std::size_t>(p.getEncodedSize()))};
  CHECK_EQUAL(static_cast<int>(e.data.size()), p.encode(e.data.data(), 0, static_cast<int>(e.data.size())));
  return e;
}

// The stream's pairs as the ground keeps them: a dataset folder of the JPEG-decoded pixels (PGM), the
// a-priori models (.cahvor) and panorama.json with the stream's rig values, for areomap-ties.
void writeDecodedDataset(const std::vector<LogEvent>& events, const std::string& dir) {
  platform::TurboJpegCodec codec;
  CHECK_EQUAL(Status::kOk, codec.open());
  std::filesystem::create_directories(dir + "/images");
  std::filesystem::create_directories(dir + "/models");
  Dataset d;
  d.root = dir;
  std::vector<uint8_t> pixels(kMaxImagePixels);
  for (const LogEvent& e : events) {
    const stereo_pair_t p = decodePair(e);
    if (p.kind != stereo_pair_t::KIND_PAIR) continue;
    d.name = p.panorama;
    Pair pair;
    pair.id = p.pair_id;
    pair.sol = p.sol;
    pair.tier = p.tier;
    const stereo_image_t* sides[2] = {&p.left, &p.right};
    for (int s = 0; s < (p.has_right ? 2 : 1); ++s) {
      int32_t w = 0, h = 0;
      CHECK_EQUAL(Status::kOk, codec.decodeGray(sides[s]->jpeg.data(), sides[s]->jpeg.size(), pixels.data(),
                                                pixels.size(), w, h));
      const std::string image = "images/" + sides[s]->stem + ".pgm";
      std::ofstream pgm(dir + "/" + image, std::ios::binary);
      pgm << "P5\n" << w << " " << h << "\n255\n";
      pgm.write(reinterpret_cast<const char*>(pixels.data()), static_cast<std::streamsize>(w) * h);
      CHECK_TRUE(pgm.good());
      CameraModel model;
      const char* field = "";
      CHECK_EQUAL(Status::kOk, toCameraModel(sides[s]->model, model, field));
      const std::string model_rel = "models/" + sides[s]->stem + ".cahvor";
      io::writeCameraModelFile(dir + "/" + model_rel, model);
      (s == 0 ? pair.left : pair.right.emplace()) = makeImageRef(dir, image, model_rel);
    }
    d.rig.gimbal_m[p.sol] = Eigen::Vector3d(p.gimbal_m[0], p.gimbal_m[1], p.gimbal_m[2]);
    d.rig.left_offset_m = Eigen::Vector3d(p.left_offset_m[0], p.left_offset_m[1], p.left_offset_m[2]);
    d.rig.right_offset_m = Eigen::Vector3d(p.right_offset_m[0], p.right_offset_m[1], p.right_offset_m[2]);
    if (p.has_right) d.rig.base_m = Eigen::Vector3d(p.base_m[0], p.base_m[1], p.base_m[2]);
    d.rig.sigma_gimbal_m = p.sigma_gimbal_m;
    d.rig.sigma_base_m = p.sigma_base_m;
    d.pairs.push_back(pair);
  }
  writeDataset(d, dir);
}

// Pixel-equivalent difference of two adjusted CAHVOR models of the same camera (their photogrammetric EO).
double modelDifferencePx(const CameraModel& a, const CameraModel& b) {
  PhotogrammetricCamera ca, cb;
  ConversionResidual residual;
  CHECK_EQUAL(Status::kOk, cahvorToPhotogrammetric(a, ca, residual));
  CHECK_EQUAL(Status::kOk, cahvorToPhotogrammetric(b, cb, residual));
  return eoPixelEquivalent(ca.io.f_px, ca.eo.centre_m - cb.eo.centre_m, rotationAngle(ca.m, cb.m), 5.0);
}

// Largest pixel-equivalent EO difference between two networks with the same images.
double maxEoDifferencePx(const Network& a, const Network& b) {
  double worst = 0.0;
  for (int32_t i = 0; i < a.imageCount(); ++i) {
    const NetImage& x = a.image(i);
    const NetImage& y = b.image(i);
    worst =
        std::max(worst, eoPixelEquivalent(x.io.f_px, x.centre_m - y.centre_m, rotationAngle(x.m, y.m), 5.0));
  }
  return worst;
}

}  // namespace

TEST_GROUP(RoverMemq){};

// The tiny panorama through memq:// in one process: every pair accepted, the final EO published, zero heap
// allocations in the pipeline across the whole panorama; and the offline tool `areomap-ties --adjust` on the
// same JPEG-decoded pixels (the stream's pairs written as a dataset folder, as the ground keeps them) makes
// the IDENTICAL tie list (same points, images, kinds, coordinates to the last bit) and the same EO within
// 0.01 px equivalent after the rover's final adjustment.
TEST(RoverMemq, TinyEndToEndEqualsTheTiesToolAndZeroHeap) {
  const Dataset dataset = readDataset(tinyDataset());
  uint64_t allocs = 99;
  const Captured c = runThroughMemq(test::tinyPackStream(), allocs);
  const RoverCounters& k = node().counters();
  std::printf(
      "rover memq tiny: %d pairs accepted of %d, final rms %.4f px, %d sweeps, %d tie-point and %d DEM "
      "messages (%zu observations), pipeline heap allocations %llu (heap counter %s)\n",
      k.pairs_accepted, k.pairs_seen, k.last_rms_px, k.last_sweeps, c.tiepoints, c.dems, c.ties.size(),
      static_cast<unsigned long long>(allocs), heapCounterActive() ? "on" : "off");
  CHECK_EQUAL(static_cast<int>(dataset.pairs.size()), k.pairs_accepted);
  CHECK_EQUAL(0, k.pairs_rejected);
  CHECK_TRUE(c.have_final);
  CHECK_EQUAL(2 * static_cast<int>(dataset.pairs.size()), c.last_eo.num_images);
  CHECK_EQUAL(static_cast<int>(dataset.pairs.size()), c.tiepoints);
  CHECK_EQUAL(static_cast<int>(dataset.pairs.size()), c.dems);
  CHECK_EQUAL(0, k.tie_overflow);
  CHECK_EQUAL(rover_status_t::STATE_FINISHED, c.last_status.state);
  if (heapCounterActive()) CHECK_EQUAL(0u, allocs);

  const std::string dir = test::scratchDir("rover-vs-ties");
  writeDecodedDataset(test::tinyPackStream(), dir + "/stream");
  CHECK_EQUAL(0, test::runTool("areomap-ties", dir + "/stream --out " + dir + "/ties --adjust"));
  const std::vector<ImageObservation> ties = readTiePointsCsv(dir + "/ties/tiepoints.csv");
  CHECK_EQUAL(ties.size(), c.ties.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < std::min(ties.size(), c.ties.size()); ++i) {
    const ImageObservation& t = ties[i];
    const ImageObservation& r = c.ties[i];
    if (t.point != r.point || t.image != r.image || t.sample_px != r.sample_px || t.line_px != r.line_px ||
        t.kind != r.kind) {
      ++differ;
    }
  }
  double worst = 0.0;
  for (int32_t i = 0; i < c.last_eo.num_images; ++i) {
    const eo_entry_t& e = c.last_eo.images[static_cast<std::size_t>(i)];
    CameraModel rover;
    const char* field = "";
    CHECK_EQUAL(Status::kOk, toCameraModel(e.model, rover, field));
    const CameraModel tool =
        io::readCameraModelFile(dir + "/ties/models/" + e.stem + ".cahvor", rover.width, rover.height);
    worst = std::max(worst, modelDifferencePx(rover, tool));
  }
  std::printf(
      "rover vs areomap-ties --adjust on the same pixels: %zu vs %zu tie observations, %zu differ; final EO "
      "max %.6f px equivalent\n",
      c.ties.size(), ties.size(), differ, worst);
  CHECK_EQUAL(0u, differ);
  CHECK_TRUE(worst < 0.01);
}

// A stream with injected faults: each counted under its own cause, the rest processed, no crash, and the
// final result as good as without the faulty pairs: the rover run on the same stream with the faulty pairs
// simply removed accepts the same pairs and ends at the same EO (within 1e-6 px equivalent).
TEST(RoverMemq, InjectedFaultsCountedAndResultAsWithoutTheFaultyPairs) {
  const std::vector<LogEvent> faulty = injectFaults(
      test::tinyPackStream(),
      "drop:2,dup:3,swap:5,truncate:4,corrupt-jpeg:6,unknown-channel,wrong-type,oversize:7,nan-model:1");
  uint64_t allocs = 99;
  const Captured c = runThroughMemq(faulty, allocs);
  const RoverCounters& k = node().counters();
  auto cause = [&](Status s) { return k.rejected_by_cause[static_cast<int>(s)]; };
  std::printf(
      "faults: seen %d accepted %d rejected %d; gaps %d duplicates %d reordered %d; truncated %d corrupt %d "
      "capacity %d unsupported %d not_finite %d; heap %llu; last error: %s\n",
      k.pairs_seen, k.pairs_accepted, k.pairs_rejected, k.sequence_gaps, k.duplicates, k.reordered,
      cause(Status::kTruncated), cause(Status::kCorruptData), cause(Status::kCapacityExceeded),
      cause(Status::kUnsupported), cause(Status::kNotFinite), static_cast<unsigned long long>(allocs),
      node().lastError());
  CHECK_EQUAL(2, k.sequence_gaps);  // pair 2 dropped; pair 4 truncated (its sequence cannot be read)
  CHECK_EQUAL(1, k.duplicates);     // pair 3 twice
  CHECK_EQUAL(1, k.reordered);      // 5 after 6
  CHECK_EQUAL(1, cause(Status::kTruncated));
  CHECK_EQUAL(1, cause(Status::kCorruptData));
  CHECK_EQUAL(1, cause(Status::kCapacityExceeded));
  CHECK_EQUAL(1, cause(Status::kUnsupported));
  CHECK_EQUAL(1, cause(Status::kNotFinite));
  CHECK_EQUAL(5, k.pairs_rejected);
  // Pairs 0, 3, 5 processed (1 NaN model, 2 dropped, 4 truncated, 6 corrupt JPEG, 7 oversize).
  CHECK_EQUAL(3, k.pairs_accepted);
  CHECK_TRUE(c.have_final);
  CHECK_EQUAL(rover_status_t::STATE_FINISHED, c.last_status.state);
  CHECK_EQUAL(2, c.last_status.sequence_gaps);
  CHECK_EQUAL(1, c.last_status.rejected_by_cause[rover_status_t::CAUSE_NOT_FINITE]);
  if (heapCounterActive()) CHECK_EQUAL(0u, allocs);
  const auto with_faults = std::make_unique<Network>(node().network());
  std::vector<std::string> stems_with_faults;
  for (int32_t i = 0; i < with_faults->imageCount(); ++i)
    stems_with_faults.emplace_back(node().stemOfImage(i));
  const double rms_with_faults = k.last_rms_px;

  // The same stream with the faulty pairs removed (1, 2, 4, 6, 7): the clean messages of 0, 3, 5, the marker.
  std::vector<LogEvent> clean;
  for (int seq : {0, 3, 5, 8}) clean.push_back(test::tinyPackStream()[static_cast<std::size_t>(seq)]);
  const Captured w = runThroughMemq(clean, allocs);
  CHECK_TRUE(w.have_final);
  CHECK_EQUAL(3, node().counters().pairs_accepted);
  CHECK_EQUAL(0, node().counters().pairs_rejected);
  CHECK_EQUAL(with_faults->imageCount(), node().network().imageCount());
  CHECK_EQUAL(with_faults->pointCount(), node().network().pointCount());
  CHECK_EQUAL(with_faults->observationCount(), node().network().observationCount());
  for (int32_t i = 0; i < node().network().imageCount(); ++i)
    STRCMP_EQUAL(stems_with_faults[static_cast<std::size_t>(i)].c_str(), node().stemOfImage(i));
  const double diff = maxEoDifferencePx(node().network(), *with_faults);
  std::printf(
      "faulty stream vs the same stream without the faulty pairs: same %d pairs accepted, final EO max %.3g "
      "px equivalent, rms %.6f vs %.6f px\n",
      node().counters().pairs_accepted, diff, rms_with_faults, node().counters().last_rms_px);
  CHECK_TRUE(diff < 1e-6);
}

// More pairs than kMaxPairs: the tiny panorama, then untextured pairs (far away, so that
// nothing is predicted into them) up to kMaxPairs, then one pair more. That pair is rejected under
// capacity_exceeded, and the panorama the rover has is kept: the final EO equals the run of the tiny pairs
// alone with the same plan.
TEST(RoverMemq, MorePairsThanCapacityRejectedPanoramaKept) {
  const std::vector<LogEvent>& tiny = test::tinyPackStream();
  const int real = static_cast<int>(tiny.size()) - 1;
  platform::TurboJpegCodec codec;
  CHECK_EQUAL(Status::kOk, codec.open());
  const stereo_pair_t first = decodePair(tiny[0]);
  const int32_t w = first.left.width_px, h = first.left.height_px;
  std::vector<uint8_t> flat(static_cast<std::size_t>(w) * h, 128), jpeg(codec.maxEncodedBytes(w, h));
  std::size_t bytes = 0;
  CHECK_EQUAL(Status::kOk, codec.encodeGray(flat.data(), w, h, 95, jpeg.data(), jpeg.size(), bytes));
  std::vector<LogEvent> full, alone;
  int64_t seq = 0;
  auto add = [&](stereo_pair_t p, std::vector<LogEvent>& out) {
    p.sequence = seq++;
    p.pair_id = static_cast<int32_t>(p.sequence);
    p.pairs_planned = kMaxPairs + 1;
    out.push_back(encodePair(p, 1'700'000'000'000'000 + p.sequence));
  };
  for (int i = 0; i < real; ++i) add(decodePair(tiny[static_cast<std::size_t>(i)]), full);
  for (int i = real; i < kMaxPairs; ++i) {
    stereo_pair_t p = first;
    for (stereo_image_t* side : {&p.left, &p.right}) {
      side->stem = "flat" + std::to_string(i) + (side == &p.left ? "L" : "R");
      side->jpeg.assign(jpeg.begin(), jpeg.begin() + static_cast<long>(bytes));
      side->jpeg_bytes = static_cast<int32_t>(bytes);
      for (int a = 0; a < 3; ++a) side->model.c_m[a] += 1e4 * side->model.a[a];
    }
    add(p, full);
  }
  add(first, full);  // pair kMaxPairs + 1
  stereo_pair_t end = decodePair(tiny.back());
  add(end, full);
  seq = 0;
  for (int i = 0; i < real; ++i) add(decodePair(tiny[static_cast<std::size_t>(i)]), alone);
  add(end, alone);

  uint64_t allocs = 99;
  const Captured c = runThroughMemq(full, allocs);
  const RoverCounters& k = node().counters();
  std::printf("capacity: %d pairs seen, %d accepted, %d without texture, %d over capacity; last error: %s\n",
              k.pairs_seen, k.pairs_accepted, k.no_texture_pairs,
              k.rejected_by_cause[static_cast<int>(Status::kCapacityExceeded)], node().lastError());
  CHECK_EQUAL(kMaxPairs + 2, k.pairs_seen);
  CHECK_EQUAL(real, k.pairs_accepted);
  CHECK_EQUAL(kMaxPairs - real, k.no_texture_pairs);
  CHECK_EQUAL(1, k.rejected_by_cause[static_cast<int>(Status::kCapacityExceeded)]);
  CHECK_EQUAL(kMaxPairs - real + 1, k.pairs_rejected);
  CHECK_TRUE(c.have_final);
  CHECK_EQUAL(rover_status_t::STATE_FINISHED, c.last_status.state);
  CHECK_EQUAL(1, c.last_status.rejected_by_cause[rover_status_t::CAUSE_CAPACITY_EXCEEDED]);
  CHECK_EQUAL(2 * real, c.last_eo.num_images);
  if (heapCounterActive()) CHECK_EQUAL(0u, allocs);
  const auto kept = std::make_unique<Network>(node().network());

  const Captured a = runThroughMemq(alone, allocs);
  CHECK_TRUE(a.have_final);
  CHECK_EQUAL(kept->observationCount(), node().network().observationCount());
  const double diff = maxEoDifferencePx(node().network(), *kept);
  std::printf("capacity: final EO vs the tiny pairs alone (same plan): max %.3g px equivalent\n", diff);
  CHECK_TRUE(diff < 1e-6);
}

// More tie points than kMaxTiePoints: the tiny panorama repeated in groups 1 km apart (a
// sol each, so nothing is predicted from one group into another) until the matcher's point list runs full.
// The pair in which it runs full and every later pair are rejected under capacity_exceeded, the network
// keeps the pairs accepted before, and the final EO of those is published. (Incremental solves capped at a
// few sweeps: only the bookkeeping is under test here.)
TEST(RoverMemq, TiePointsAtCapacityRejectedPanoramaKept) {
  const std::vector<LogEvent>& tiny = test::tinyPackStream();
  const int real = static_cast<int>(tiny.size()) - 1;
  std::vector<LogEvent> stream;
  int64_t seq = 0;
  const int groups = 10;  // ~990 points per group of 8 pairs: the 8192 run out in the 9th
  for (int g = 0; g < groups; ++g) {
    for (int i = 0; i < real; ++i) {
      stereo_pair_t p = decodePair(tiny[static_cast<std::size_t>(i)]);
      p.sequence = seq++;
      p.pair_id = static_cast<int32_t>(p.sequence);
      p.sol = g;
      p.pairs_planned = real;  // the tiny plan (256 ties per pair), not the 80 pairs of the stream
      p.gimbal_m[1] += 1000.0 * g;
      for (stereo_image_t* side : {&p.left, &p.right}) {
        side->stem += "g" + std::to_string(g);
        side->model.c_m[1] += 1000.0 * g;
      }
      stream.push_back(encodePair(p, 1'700'000'000'000'000 + p.sequence));
    }
  }
  stereo_pair_t end = decodePair(tiny.back());
  end.sequence = seq;
  stream.push_back(encodePair(end, 1'700'000'000'000'000 + seq));
  RoverOptions options;
  options.adjust.max_sweeps = 3;
  uint64_t allocs = 99;
  const Captured c = runThroughMemq(stream, allocs, options);
  const RoverCounters& k = node().counters();
  const int full = k.rejected_by_cause[static_cast<int>(Status::kCapacityExceeded)];
  std::printf(
      "tie points at capacity: %d pairs seen, %d accepted, %d rejected as workspace full, network %d images "
      "%d points; last error: %s\n",
      k.pairs_seen, k.pairs_accepted, full, node().network().imageCount(), node().network().pointCount(),
      node().lastError());
  CHECK_TRUE(full >= 1);
  CHECK_EQUAL(groups * real, k.pairs_accepted + full + k.no_texture_pairs);
  CHECK_EQUAL(full + k.no_texture_pairs, k.pairs_rejected);
  CHECK_TRUE(k.pairs_accepted >= real);
  CHECK_EQUAL(2 * k.pairs_accepted, node().network().imageCount());
  CHECK_TRUE(c.have_final);
  CHECK_EQUAL(2 * k.pairs_accepted, c.last_eo.num_images);
  CHECK_EQUAL(rover_status_t::STATE_FINISHED, c.last_status.state);
  CHECK_EQUAL(full, c.last_status.rejected_by_cause[rover_status_t::CAUSE_CAPACITY_EXCEEDED]);
  if (heapCounterActive()) CHECK_EQUAL(0u, allocs);
}

// A two-site tiny traverse of 4 pairs a site (areomap-pack of traverse.json: each site announced, then its
// pairs and end marker) through the node in one run: both sites mapped, a final EO per site tagged with its panorama,
// zero heap allocations in the pipeline over both sites (the reset between sites included), endOfRun()
// only after the last site; and the second site's final EO identical to the node's on that site alone
// (nothing of the first site is left in the workspaces).
TEST(RoverMemq, TwoSiteTraverseHeapFreeAndEachSiteAsAlone) {
  const std::string ds = test::scratchDir("rover-traverse") + "/ds";
  CHECK_EQUAL(0, test::runTool("areomap-sim",
                               "--preset traverse --camera tiny --pairs 4 --sites 2 --seed 3 --leg-min-m 10 "
                               "--leg-max-m 12 --out " +
                                   ds));
  const Traverse traverse = readTraverse(ds);
  PackOptions options;
  options.start_utime = 1'700'000'000'000'000;
  const std::vector<LogEvent> events = packTraverse(traverse, options);
  uint64_t allocs = 99;
  const Captured both = runThroughMemq(events, allocs);
  const RoverCounters k = node().counters();
  const Dataset site1 = readDataset(traverse.sites[0].dir), site2 = readDataset(traverse.sites[1].dir);
  std::printf(
      "rover memq 2-site traverse: %d + %zu pairs, %d accepted, %d sites announced, %zu final EOs, "
      "pipeline heap allocations %llu (heap counter %s)\n",
      static_cast<int>(site1.pairs.size()), site2.pairs.size(), k.pairs_accepted, k.sites_announced,
      both.finals.size(), static_cast<unsigned long long>(allocs), heapCounterActive() ? "on" : "off");
  CHECK_EQUAL(static_cast<int>(site1.pairs.size() + site2.pairs.size()), k.pairs_accepted);
  CHECK_EQUAL(0, k.pairs_rejected);
  CHECK_EQUAL(2, k.sites_announced);
  CHECK_EQUAL(0, k.sites_rejected);
  CHECK_EQUAL(0, k.sequence_gaps);
  CHECK_EQUAL(0, k.duplicates);
  CHECK_EQUAL(2u, both.finals.size());
  STRCMP_EQUAL(site1.name.c_str(), both.finals[0].panorama.c_str());
  STRCMP_EQUAL(site2.name.c_str(), both.finals[1].panorama.c_str());
  CHECK_EQUAL(2 * static_cast<int>(site2.pairs.size()), both.finals[1].num_images);
  CHECK_TRUE(node().endOfRun());
  if (heapCounterActive()) CHECK_EQUAL(0u, allocs);

  // endOfRun() waits for the last site: after the first site's marker it is still false.
  std::vector<LogEvent> first_site;
  for (const LogEvent& e : events) {
    first_site.push_back(e);
    if (first_site.size() == site1.pairs.size() + 2) break;  // announcement, pairs, marker
  }
  (void)runThroughMemq(first_site, allocs);
  CHECK_TRUE(node().counters().finished);
  CHECK_FALSE(node().endOfRun());

  // Site 2 alone (its own announcement, pairs and marker) gives the same final EO, bit for bit.
  const std::vector<LogEvent> second_site(events.begin() + static_cast<long>(site1.pairs.size() + 2),
                                          events.end());
  const Captured alone = runThroughMemq(second_site, allocs);
  CHECK_EQUAL(1u, alone.finals.size());
  CHECK_EQUAL(alone.finals[0].num_images, both.finals[1].num_images);
  double worst = 0.0;
  for (int32_t i = 0; i < alone.finals[0].num_images; ++i) {
    const eo_entry_t& a = alone.finals[0].images[static_cast<std::size_t>(i)];
    const eo_entry_t& b = both.finals[1].images[static_cast<std::size_t>(i)];
    STRCMP_EQUAL(a.stem.c_str(), b.stem.c_str());
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(a.center_m[c] - b.center_m[c]));
    worst = std::max({worst, std::abs(a.omega_rad - b.omega_rad), std::abs(a.phi_rad - b.phi_rad),
                      std::abs(a.kappa_rad - b.kappa_rad)});
  }
  std::printf("site 2 in the traverse vs alone: largest EO difference %.3g (m or rad)\n", worst);
  CHECK_EQUAL(0.0, worst);
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
              node().counters().pairs_accepted, node().counters().pairs_seen, c.last_eo.num_images,
              c.last_eo.rms_px, static_cast<unsigned long long>(allocs));
  CHECK_EQUAL(2, node().counters().pairs_accepted);
  CHECK_TRUE(c.have_final);
  CHECK_EQUAL(2, c.last_eo.num_images);
  if (heapCounterActive()) CHECK_EQUAL(0u, allocs);
}
