// The ground node: SHA-256 against the FIPS 180-4 examples; the stream collector's fault counting; the
// tiny panorama end to end through memq:// in one process (a camera stream packed here from the dataset,
// JPEG quality 95, as areomap-pack does), products and report checked against the simulator's truth.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include <sys/wait.h>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "areomap/product_t.hpp"
#include "areomap/rover_status_t.hpp"
#include "areomap/site_pose_t.hpp"
#include "areomap/stereo_pair_t.hpp"
#include "areomap/tiepoints_t.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/io/ImageFile.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/node/EventRecorder.hpp"
#include "ground/node/GroundNode.hpp"
#include "ground/pack/Pack.hpp"
#include "ground/cli/Sha256.hpp"
#include "ground/node/StreamCollector.hpp"
#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
#include "platform/posix/LcmLogReplay.hpp"
#include "platform/posix/TurboJpegCodec.hpp"
#include "platform/stub/MemoryTransport.hpp"
#include "tests/ground/pack/TinyStream.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using json = nlohmann::json;

namespace {

// The tiny simulated panorama (8 pairs), made once per process.
const std::string& tinyDataset() {
  static const std::string dir = test::makeTinyDataset("ground-node-tiny");
  CHECK(!dir.empty());
  return dir;
}

// The camera stream of the tiny dataset as areomap-pack makes it.
const std::vector<LogEvent>& tinyStream() {
  static const std::vector<LogEvent> events = test::packedStream(tinyDataset());
  return events;
}

void feed(ground::StreamCollector& c, const std::vector<LogEvent>& events) {
  for (const LogEvent& e : events) c.receive(e.channel, e.data.data(), e.data.size());
}

json readNodeReport(const std::string& path) {
  std::ifstream in(path);
  json j;
  in >> j;
  return j;
}

template <class Message>
std::vector<uint8_t> encoded(Message& m) {
  std::vector<uint8_t> bytes(static_cast<std::size_t>(m.getEncodedSize()));
  CHECK(m.encode(bytes.data(), 0, static_cast<int>(bytes.size())) == static_cast<int>(bytes.size()));
  return bytes;
}

// What a rover would send for a panorama whose tie observations are `ties` (one TIEPOINTS message per pair,
// all observations in the first; sequences from `first_sequence`), then RUNNING and FINISHED statuses.
std::vector<LogEvent> roverMessages(const Dataset& d, const std::vector<ImageObservation>& ties, int64_t first_sequence) {
  std::vector<std::string> stems;
  for (const ImageObservation& o : ties) {
    if (std::find(stems.begin(), stems.end(), o.image) == stems.end()) stems.push_back(o.image);
  }
  std::vector<LogEvent> events;
  for (std::size_t p = 0; p < d.pairs.size(); ++p) {
    tiepoints_t m{};
    m.sequence = first_sequence + static_cast<int64_t>(p);
    m.panorama = d.name;
    m.pair_id = d.pairs[p].id;
    m.num_images = static_cast<int32_t>(stems.size());
    m.image_stems = stems;
    if (p == 0) {
      for (const ImageObservation& o : ties) {
        m.point_id.push_back(static_cast<int32_t>(o.point));
        m.image_index.push_back(static_cast<int16_t>(std::find(stems.begin(), stems.end(), o.image) - stems.begin()));
        m.sample_px.push_back(o.sample_px);
        m.line_px.push_back(o.line_px);
        m.kind.push_back(o.kind == "inter" ? int8_t{tiepoints_t::KIND_INTER} : int8_t{tiepoints_t::KIND_INTRA});
      }
    }
    m.num_observations = static_cast<int32_t>(m.point_id.size());
    events.push_back(LogEvent{channels::kTiePoints, 0, encoded(m)});
  }
  for (int8_t state : {rover_status_t::STATE_RUNNING, rover_status_t::STATE_FINISHED}) {
    rover_status_t st{};
    st.sequence = first_sequence + (state == rover_status_t::STATE_RUNNING ? 0 : 1);
    st.state = state;
    events.push_back(LogEvent{channels::kRoverStatus, 0, encoded(st)});
  }
  return events;
}

std::string fileText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void onProduct(void* context, const char*, const uint8_t* data, std::size_t size) {
  auto* product = static_cast<product_t*>(context);
  CHECK(ok(msgs::decodeMessage(data, size, *product)));
}

}  // namespace

TEST_GROUP(Sha256){};

// FIPS 180-4 / NIST examples: "", "abc", the 448-bit message, and one million 'a' (many blocks).
TEST(Sha256, MatchesTheNistExamples) {
  STRCMP_EQUAL("e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855", cli::sha256Hex("").c_str());
  STRCMP_EQUAL("ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad", cli::sha256Hex("abc").c_str());
  STRCMP_EQUAL("248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1",
               cli::sha256Hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq").c_str());
  STRCMP_EQUAL("cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0",
               cli::sha256Hex(std::string(1000000, 'a')).c_str());
}

TEST_GROUP(StreamFaults){};

// Dropped, duplicated, reordered, truncated, corrupt-JPEG, wrong-type, unknown-channel and over-capacity
// messages: each counted under its own cause, the rest kept, the gap named in a warning.
TEST(StreamFaults, EveryFaultIsCountedUnderItsCause) {
  // The pack engineer's injection (ground/pack/Pack.hpp), as in the rover's fault test.
  const std::vector<LogEvent> faulty = injectFaults(
      tinyStream(), "drop:2,dup:3,swap:5,truncate:4,corrupt-jpeg:6,unknown-channel,wrong-type,oversize:7,nan-model:1");
  ground::StreamCollector c;
  feed(c, faulty);
  const ground::StreamCounts counts = c.counts();
  for (const auto& [cause, n] : counts.rejected) std::printf("rejected %s: %d\n", cause.c_str(), n);
  for (const std::string& w : counts.warnings) std::printf("warning: %s\n", w.c_str());
  std::printf("pairs %d gaps %d duplicates %d reordered %d\n", counts.pairs, counts.gaps, counts.duplicates,
              counts.reordered);
  const int32_t n = static_cast<int32_t>(tinyStream().size()) - 1;  // pairs
  CHECK_EQUAL(n - 5, counts.pairs);  // lost: 1 NaN model, 2 dropped, 4 truncated, 6 JPEG, 7 over capacity
  CHECK_EQUAL(2, counts.gaps);       // 2 and 4 never arrived intact (a truncated message has no sequence)
  CHECK_EQUAL(1, counts.duplicates);
  CHECK_EQUAL(1, counts.reordered);
  CHECK_EQUAL(1, counts.rejected.at("jpeg_corrupt_data"));
  CHECK_EQUAL(1, counts.rejected.at("truncated"));
  CHECK_EQUAL(1, counts.rejected.at("wrong_type"));
  CHECK_EQUAL(1, counts.rejected.at("unknown_channel"));
  CHECK_EQUAL(1, counts.rejected.at("capacity_exceeded"));
  CHECK_EQUAL(1, counts.rejected.at("model_not_finite"));
  CHECK(counts.end_of_panorama);
  bool named = false;
  for (const std::string& w : counts.warnings) named = named || w.find("message 2 ") != std::string::npos;
  CHECK(named);
}

TEST_GROUP(GroundEndToEnd){};

// The tiny panorama through memq:// in one process: products written, the manifest published, the report's
// stream figures exact, and the integrated adjustment better than the a-priori EO against the truth.
TEST(GroundEndToEnd, TinyThroughMemq) {
  const Dataset d = readDataset(tinyDataset());
  std::vector<uint8_t> storage(96u * 1024u * 1024u);
  platform::MemoryTransport memq(storage.data(), storage.size());
  for (const LogEvent& e : tinyStream()) CHECK(ok(memq.publish(e.channel.c_str(), e.data.data(), e.data.size())));
  product_t product;
  CHECK(ok(memq.subscribe(channels::kProduct, &onProduct, &product)));
  ground::GroundNodeOptions options;
  options.pass.out_dir = test::scratchDir("ground-node-memq");
  options.pass.truth_dir = tinyDataset();
  options.pass.progress = false;
  options.rover_wait_s = 0.0;
  options.rover_silent_s = 0.0;
  const ground::GroundNodeResult r = ground::runGroundNode(memq, "memq://", options);
  CHECK(r.product_published);
  while (ok(memq.handle(0))) {
  }
  const std::string out = options.pass.out_dir;
  std::printf("tiny via memq: %d pairs, %d points, method 1 %.3f -> %.3f px (fast %.3f), truth EO %.3f -> %.3f px "
              "(fast %.3f), fast vs integrated %.4f px, %zu files\n",
              r.pass.summary.pairs, r.pass.summary.points, r.pass.summary.method1_before_px,
              r.pass.summary.method1_after_px, r.pass.summary.method1_fast_px,
              r.pass.summary.truth_eo_before_px.value_or(-1), r.pass.summary.truth_eo_after_px.value_or(-1),
              r.pass.summary.truth_eo_fast_px.value_or(-1), r.pass.summary.fast_vs_ground_px.value_or(-1),
              r.files.size());
  CHECK_EQUAL(static_cast<int32_t>(d.pairs.size()), r.stream.pairs);
  CHECK_EQUAL(0, r.stream.gaps);
  for (const Pair& p : d.pairs) {
    CHECK(test::fileExists(out + "/models/" + p.left.stem + ".cahvor"));
    // The image kept by the ground is the stream's JPEG decoded: within JPEG error of the original.
    const cv::Mat kept = cv::imread(out + "/stream/images/" + p.left.stem + ".png", cv::IMREAD_GRAYSCALE);
    const cv::Mat original = io::loadImage8(p.left.image_path);
    CHECK(kept.size() == original.size());
    CHECK(cv::norm(kept, original, cv::NORM_L1) / kept.total() < 3.0);
  }
  for (const char* f : {"eo.csv", "tiepoints.csv", "report.json"}) CHECK(test::fileExists(out + "/" + f));
  const json report = readNodeReport(out + "/report.json");
  CHECK_EQUAL(static_cast<int>(d.pairs.size()), report["stream"]["pairs"].get<int>());
  CHECK_EQUAL(0, report["stream"]["gaps"].get<int>());
  CHECK(report.contains("method1_px") && report.contains("truth") && report.contains("warnings"));
  CHECK(r.pass.summary.method1_after_px < r.pass.summary.method1_before_px);
  CHECK(r.pass.summary.truth_eo_after_px.has_value());
  CHECK(*r.pass.summary.truth_eo_after_px < *r.pass.summary.truth_eo_before_px);
  // The manifest names every product with its size and checksum, and nothing of stream/.
  CHECK_EQUAL(static_cast<int32_t>(r.files.size()), product.num_files);
  bool has_report = false;
  for (int32_t k = 0; k < product.num_files; ++k) {
    CHECK(product.names[k].rfind("stream/", 0) != 0);
    if (product.names[k] == "report.json") {
      has_report = true;
      CHECK_EQUAL(static_cast<int64_t>(std::filesystem::file_size(out + "/report.json")), product.bytes[k]);
      STRCMP_EQUAL(cli::sha256File(out + "/report.json").c_str(), product.sha256_hex[k].c_str());
    }
  }
  CHECK(has_report);
}

TEST_GROUP(GroundRecording){};

// The node's recording is a standard LCM log: LcmLogReplay (file://) gives back every event, byte for byte;
// a half-written last event (a kill in the middle of a write) ends the replay as kTruncated, the events
// before it intact.
TEST(GroundRecording, ReplaysByteForByteAndDropsAHalfWrittenTail) {
  const std::string dir = test::scratchDir("ground-recording");
  const std::string path = dir + "/" + ground::kRecordingName;
  const std::vector<LogEvent>& events = tinyStream();
  {
    ground::EventRecorder recorder;
    recorder.open(path);
    for (const LogEvent& e : events) recorder.record(e.channel.c_str(), e.data.data(), e.data.size());
    CHECK_EQUAL(static_cast<int64_t>(events.size()), recorder.events());
    CHECK_EQUAL(0, recorder.writeErrors());
  }
  const auto full = std::filesystem::file_size(path);
  std::filesystem::resize_file(path, full - 5);  // the last event (the end marker) cut short
  struct Received {
    std::vector<std::string> channels;
    std::vector<std::vector<uint8_t>> data;
  } got;
  std::vector<uint8_t> buffer(16u * 1024u * 1024u);
  platform::LcmLogReplay replay(buffer.data(), buffer.size());
  CHECK(ok(replay.open(("file://" + path).c_str())));
  for (const char* channel : {channels::kStereoPair}) {
    CHECK(ok(replay.subscribe(channel, [](void* c, const char* ch, const uint8_t* d, std::size_t n) {
      auto* r = static_cast<Received*>(c);
      r->channels.emplace_back(ch);
      r->data.emplace_back(d, d + n);
    }, &got)));
  }
  Status s = Status::kOk;
  while (ok(s)) s = replay.handle(0);
  CHECK_EQUAL(static_cast<int>(Status::kTruncated), static_cast<int>(s));
  CHECK_EQUAL(events.size() - 1, got.data.size());
  for (std::size_t k = 0; k < got.data.size(); ++k) {
    STRCMP_EQUAL(events[k].channel.c_str(), got.channels[k].c_str());
    CHECK(events[k].data == got.data[k]);
  }
}

// A recording on a full disk (/dev/full: every write fails with ENOSPC): each lost message is counted, the
// node goes on and makes the panorama from what it received; the counts reach the result (areomap-ground
// then names the recording among the files not written and exits 1).
TEST(GroundRecording, AFullDiskIsCountedAndThePanoramaIsStillMade) {
  if (!std::filesystem::exists("/dev/full")) {
    std::printf("SKIP: no /dev/full on this system\n");
    return;
  }
  const Dataset d = readDataset(tinyDataset());
  std::vector<uint8_t> storage(96u * 1024u * 1024u);
  platform::MemoryTransport memq(storage.data(), storage.size());
  for (const LogEvent& e : tinyStream()) CHECK(ok(memq.publish(e.channel.c_str(), e.data.data(), e.data.size())));
  ground::GroundNodeOptions options;
  options.pass.out_dir = test::scratchDir("ground-node-recording-full");
  options.pass.progress = false;
  options.rover_wait_s = 0.0;
  options.rover_silent_s = 0.0;
  options.record_path = "/dev/full";
  const ground::GroundNodeResult r = ground::runGroundNode(memq, "memq://", options);
  std::printf("recording on /dev/full: %lld recorded, %lld not recorded, %lld messages\n",
              static_cast<long long>(r.recorded), static_cast<long long>(r.record_write_errors),
              static_cast<long long>(r.messages));
  CHECK_EQUAL(0, r.recorded);
  CHECK(r.record_write_errors > 0);
  CHECK_EQUAL(r.messages, r.record_write_errors);
  CHECK_EQUAL(static_cast<int32_t>(d.pairs.size()), r.stream.pairs);
  CHECK(test::fileExists(options.pass.out_dir + "/eo.csv"));
}

TEST_GROUP(RoverTies){};

// When the rover's ties may stand for the panorama's, and the reason when not (also frames it binned).
TEST(RoverTies, CompleteOnlyWithTheFinalEoNoLossAndEveryPair) {
  Dataset d;
  for (int id : {0, 1, 2}) {
    Pair p;
    p.id = id;
    d.pairs.push_back(p);
  }
  ground::RoverInputs r;
  STRCMP_EQUAL("none arrived", ground::roverTiesIncomplete(d, r).c_str());
  r.ties.push_back(ImageObservation{});
  r.tie_pairs = {0, 1, 2};
  STRCMP_EQUAL("the rover's final EO did not arrive", ground::roverTiesIncomplete(d, r).c_str());
  r.finished = true;
  STRCMP_EQUAL("", ground::roverTiesIncomplete(d, r).c_str());
  r.tie_messages_missing = 2;
  STRCMP_EQUAL("2 AREOMAP_TIEPOINTS message(s) were lost", ground::roverTiesIncomplete(d, r).c_str());
  r.tie_messages_missing = 0;
  r.tie_pairs = {1};
  STRCMP_EQUAL("none came for pair(s) 0, 2", ground::roverTiesIncomplete(d, r).c_str());
  // Frames the rover binned: the ground matches the full-resolution frames itself.
  r.tie_pairs = {0, 1, 2};
  r.status = rover_status_t{};
  STRCMP_EQUAL("", ground::roverTiesIncomplete(d, r).c_str());
  r.status->pairs_binned = 3;
  STRCMP_EQUAL("the rover matched 3 pair(s) on frames binned to its capacity; the ground matches at full resolution",
               ground::roverTiesIncomplete(d, r).c_str());
}

// The rover's numbering goes on across panoramas: after restartAfterHighest the next panorama's messages
// are neither gaps nor duplicates, and a late message of the previous panorama is a duplicate.
TEST(RoverTies, SequencesGoOnAcrossPanoramas) {
  ground::SequenceTracker t;
  for (int64_t s : {0, 1, 2}) CHECK(t.record(s) == ground::SequenceTracker::Arrival::kInOrder);
  t.restartAfterHighest();
  CHECK(t.record(4) == ground::SequenceTracker::Arrival::kInOrder);
  CHECK(t.record(1) == ground::SequenceTracker::Arrival::kDuplicate);
  CHECK_EQUAL(1u, t.missing().size());  // 3
  CHECK_EQUAL(3, t.missing()[0]);
}

// The rover publishes a site's pose only while the site is in its window (its last few sites): the poses of
// the sites of earlier panoramas stay in the collector across panoramas, the latest of each site.
TEST(RoverTies, SitePosesAreKeptAcrossPanoramas) {
  ground::StreamCollector c;
  const auto send = [&c](const char* site, int64_t sequence, double x) {
    site_pose_t p{};
    p.site_id = site;
    p.sequence = sequence;
    p.position_m[0] = x;
    std::vector<uint8_t> bytes(static_cast<std::size_t>(p.getEncodedSize()));
    CHECK(p.encode(bytes.data(), 0, static_cast<int>(bytes.size())) == static_cast<int>(bytes.size()));
    c.receive(channels::kSitePose, bytes.data(), bytes.size());
  };
  send("site01", 0, 0.0);
  send("site02", 1, 10.0);
  c.nextPanorama();
  send("site02", 2, 11.0);
  send("site03", 3, 20.0);
  CHECK_EQUAL(3u, c.roverSitePoses().size());
  DOUBLES_EQUAL(0.0, c.roverSitePoses().at("site01").position_m[0], 0.0);
  DOUBLES_EQUAL(11.0, c.roverSitePoses().at("site02").position_m[0], 0.0);
  DOUBLES_EQUAL(20.0, c.roverSitePoses().at("site03").position_m[0], 0.0);
}

// Two panoramas in one run through memq:// (panoramas = 2): the first with no rover (the ground matches its
// own images, and says so), the second with "rover" ties that are the first pass's own tiepoints.csv (one
// TIEPOINTS message per pair, sequences going on from an earlier panorama): the second pass adjusts them
// (tie_source rover) and must give the first pass's EO -- the same observations by the other route.
TEST(GroundEndToEnd, TwoPanoramasInOneRunSecondWithRoverTies) {
  const Dataset d = readDataset(tinyDataset());
  std::vector<uint8_t> storage(128u * 1024u * 1024u);
  platform::MemoryTransport memq(storage.data(), storage.size());
  ground::GroundNodeOptions options;
  options.pass.out_dir = test::scratchDir("ground-node-two");
  options.pass.progress = false;
  options.rover_wait_s = 0.0;
  options.rover_silent_s = 0.0;
  options.panoramas = 2;
  std::vector<ground::GroundNodeResult> results;
  // Pass 1 alone first (its ties feed pass 2's rover messages), then pass 2 in the same node.
  for (const LogEvent& e : tinyStream()) CHECK(ok(memq.publish(e.channel.c_str(), e.data.data(), e.data.size())));
  bool second_fed = false;
  ground::runGroundNode(memq, "memq://", options, [&](const ground::GroundNodeResult& r) {
    results.push_back(r);
    if (second_fed) return;
    second_fed = true;
    const std::vector<ImageObservation> ties = readTiePointsCsv(r.out_dir + "/tiepoints.csv");
    // Rover messages before the pairs (as if the rover was fast), sequences going on from 5.
    for (const LogEvent& e : roverMessages(d, ties, 5)) CHECK(ok(memq.publish(e.channel.c_str(), e.data.data(), e.data.size())));
    for (const LogEvent& e : tinyStream()) CHECK(ok(memq.publish(e.channel.c_str(), e.data.data(), e.data.size())));
  });
  CHECK_EQUAL(2u, results.size());
  const std::string first = options.pass.out_dir + "/panorama-001", second = options.pass.out_dir + "/panorama-002";
  STRCMP_EQUAL(first.c_str(), results[0].out_dir.c_str());
  STRCMP_EQUAL(second.c_str(), results[1].out_dir.c_str());
  const json r1 = readNodeReport(first + "/report.json"), r2 = readNodeReport(second + "/report.json");
  STRCMP_EQUAL("ground", r1["ground"]["tie_source"].get<std::string>().c_str());
  STRCMP_EQUAL("rover", r2["ground"]["tie_source"].get<std::string>().c_str());
  bool warned = false;
  for (const auto& w : r1["warnings"]) warned = warned || w.get<std::string>().find("rover's tie points are not used") != std::string::npos;
  CHECK(warned);
  for (const auto* r : {&r1, &r2}) {
    CHECK_EQUAL(static_cast<int>(d.pairs.size()), (*r)["stream"]["pairs"].get<int>());
    CHECK_EQUAL(0, (*r)["stream"]["gaps"].get<int>());
    CHECK_EQUAL(0, (*r)["stream"]["duplicates"].get<int>());
  }
  // Same observations, other route (points in another order): the same EO to far below a pixel.
  const double dist1 = r1["method1_px"]["after"]["dist"].get<double>(), dist2 = r2["method1_px"]["after"]["dist"].get<double>();
  std::printf("two panoramas: method 1 after %.6f px (ground ties) vs %.6f px (the same ties as the rover's)\n", dist1, dist2);
  DOUBLES_EQUAL(dist1, dist2, 1e-4);
  const std::vector<std::string> eo1 = [&] {
    std::vector<std::string> v;
    std::istringstream in(fileText(first + "/eo.csv"));
    for (std::string line; std::getline(in, line);) v.push_back(line);
    return v;
  }();
  CHECK(!eo1.empty());
  const std::vector<ImageObservation> t1 = readTiePointsCsv(first + "/tiepoints.csv");
  const std::vector<ImageObservation> t2 = readTiePointsCsv(second + "/tiepoints.csv");
  CHECK_EQUAL(t1.size(), t2.size());
}
