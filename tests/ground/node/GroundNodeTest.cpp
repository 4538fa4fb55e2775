// The ground node: SHA-256 against the FIPS 180-4 examples; the stream collector's fault counting; the
// tiny panorama end to end through memq:// in one process (a camera stream packed here from the dataset,
// JPEG quality 95, as areomap-pack does), products and report checked against the simulator's truth.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <sys/wait.h>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "areomap/product_t.hpp"
#include "areomap/rover_status_t.hpp"
#include "areomap/stereo_pair_t.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/io/ImageFile.hpp"
#include "ground/node/GroundNode.hpp"
#include "ground/pack/Pack.hpp"
#include "ground/node/Sha256.hpp"
#include "ground/node/StreamCollector.hpp"
#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
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

json readJson(const std::string& path) {
  std::ifstream in(path);
  json j;
  in >> j;
  return j;
}

void onProduct(void* context, const char*, const uint8_t* data, std::size_t size) {
  auto* product = static_cast<product_t*>(context);
  CHECK(ok(msgs::decodeMessage(data, size, *product)));
}

}  // namespace

TEST_GROUP(Sha256){};

// FIPS 180-4 / NIST examples: "", "abc", the 448-bit message, and one million 'a' (many blocks).
TEST(Sha256, MatchesTheNistExamples) {
  STRCMP_EQUAL("e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855", ground::sha256Hex("").c_str());
  STRCMP_EQUAL("ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad", ground::sha256Hex("abc").c_str());
  STRCMP_EQUAL("248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1",
               ground::sha256Hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq").c_str());
  STRCMP_EQUAL("cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0",
               ground::sha256Hex(std::string(1000000, 'a')).c_str());
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
              r.pass.pairs, r.pass.points, r.pass.method1_before_px, r.pass.method1_after_px, r.pass.method1_fast_px,
              r.pass.truth_eo_before_px.value_or(-1), r.pass.truth_eo_after_px.value_or(-1),
              r.pass.truth_eo_fast_px.value_or(-1), r.pass.fast_vs_ground_px.value_or(-1), r.pass.files.size());
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
  const json report = readJson(out + "/report.json");
  CHECK_EQUAL(static_cast<int>(d.pairs.size()), report["stream"]["pairs"].get<int>());
  CHECK_EQUAL(0, report["stream"]["gaps"].get<int>());
  CHECK(report.contains("method1_px") && report.contains("truth") && report.contains("warnings"));
  CHECK(r.pass.method1_after_px < r.pass.method1_before_px);
  CHECK(r.pass.truth_eo_after_px.has_value());
  CHECK(*r.pass.truth_eo_after_px < *r.pass.truth_eo_before_px);
  // The manifest names every product with its size and checksum, and nothing of stream/.
  CHECK_EQUAL(static_cast<int32_t>(r.pass.files.size()), product.num_files);
  bool has_report = false;
  for (int32_t k = 0; k < product.num_files; ++k) {
    CHECK(product.names[k].rfind("stream/", 0) != 0);
    if (product.names[k] == "report.json") {
      has_report = true;
      CHECK_EQUAL(static_cast<int64_t>(std::filesystem::file_size(out + "/report.json")), product.bytes[k]);
      STRCMP_EQUAL(ground::sha256File(out + "/report.json").c_str(), product.sha256_hex[k].c_str());
    }
  }
  CHECK(has_report);
}
