// The rover node on frames above its image capacity (firmware_core/node/RoverNode.hpp): a rendered pair of
// real-size Navcam frames (the Perseverance CAHVORE, a textured ground plane as truth) packed as areomap-pack
// packs it; the rover bins it while decoding, maps it, counts it as pairs_binned and publishes its ties and
// models in the pixel frame of the frames as sent, with no heap allocation. A frame beyond kMaxBinning x
// the capacity is still refused, counted under capacity_exceeded.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "areomap/eo_solution_t.hpp"
#include "areomap/rover_status_t.hpp"
#include "areomap/tiepoints_t.hpp"
#include "firmware_core/camera/Binning.hpp"
#include "firmware_core/node/RoverNode.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/pack/Pack.hpp"
#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
#include "tests/ground/pass/PassChecks.hpp"
#include "tests/support/TestData.hpp"

// Includes CppUTest: after every STL, Eigen and OpenCV header.
#include "tests/ground/pack/RoverHarness.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

RoverNode& binningRover() {
  return test::harnessRover();
}

constexpr double kPlaneZ_m = 0.0;  // the rover navigation frame's ground level

// What the rover published: every tie observation (pixel coordinates by stem and point), the last EO
// solution and the last status.
struct Published {
  std::map<std::string, std::map<int32_t, Vec2>> ties;  // stem -> point -> pixel
  eo_solution_t eo;
  rover_status_t status;
  std::vector<std::string> errors;  // every status's last_error, in order
  uint64_t pipeline_allocs = 0;
};

void onBinningTies(void* ctx, const char*, const uint8_t* data, std::size_t size) {
  tiepoints_t m;
  if (!ok(msgs::decodeMessage(data, size, m))) return;
  for (int32_t i = 0; i < m.num_observations; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const std::string& stem = m.image_stems[static_cast<std::size_t>(m.image_index[k])];
    static_cast<Published*>(ctx)->ties[stem][m.point_id[k]] = Vec2(m.sample_px[k], m.line_px[k]);
  }
}
void onBinningEo(void* ctx, const char*, const uint8_t* data, std::size_t size) {
  (void)msgs::decodeMessage(data, size, static_cast<Published*>(ctx)->eo);
}
void onBinningStatus(void* ctx, const char*, const uint8_t* data, std::size_t size) {
  auto* out = static_cast<Published*>(ctx);
  if (ok(msgs::decodeMessage(data, size, out->status))) out->errors.push_back(out->status.last_error);
}

// Every event into the node, what it published captured.
Published runBinningRover(const std::vector<LogEvent>& events) {
  Published out;
  out.pipeline_allocs = test::feedRover(events, [&out](platform::MemoryTransport& outbox) {
    CHECK(ok(outbox.subscribe(channels::kTiePoints, onBinningTies, &out)));
    CHECK(ok(outbox.subscribe(channels::kEoSolution, onBinningEo, &out)));
    CHECK(ok(outbox.subscribe(channels::kRoverStatus, onBinningStatus, &out)));
  });
  return out;
}

// A dataset folder of one rendered pair (PNG images, .cahvor models), read back as areomap-pack reads it.
Dataset renderedPair(const std::string& name, const CameraModel& left, const CameraModel& right, unsigned seed) {
  const std::string root = test::scratchDir("rover-binning-" + name);
  Dataset d;
  d.root = root;
  d.name = name;
  Pair p;
  p.id = 0;
  p.sol = 1;
  const CameraModel* models[2] = {&left, &right};
  for (int side = 0; side < 2; ++side) {
    const std::string stem = name + (side == 0 ? "_L" : "_R");
    CHECK(cv::imwrite(root + "/" + stem + ".png", test::renderPlane(*models[side], kPlaneZ_m, seed)));
    io::writeCameraModelFile(root + "/" + stem + ".cahvor", *models[side]);
    const ImageRef ref = makeImageRef(root, stem + ".png", std::string(stem + ".cahvor"));
    if (side == 0) p.left = ref;
    else p.right = ref;
  }
  d.pairs.push_back(p);
  return d;
}

std::vector<LogEvent> packed(const Dataset& d) {
  PackOptions options;
  options.start_utime = 1'700'000'000'000'000;
  return packDataset(d, options);
}

}  // namespace

TEST_GROUP(RoverBinning){};

// A 1288 x 968 tile pair of the Navcam (the principal point at a tile corner, as the shared real tiles):
// binned 2 x 2 by the rover, mapped (ties found), counted; the published ties, in full-resolution pixels,
// agree with the plane seen through the full-resolution models, and the published models are in the
// frames' own pixel frame (1288 x 968); no heap allocation.
TEST(RoverBinning, TilePairIsBinnedMappedAndCounted) {
  const CameraModel left = test::tile(false, 0.0, 0.0), right = test::tile(true, 0.0, 0.0);
  const std::vector<LogEvent> events = packed(renderedPair("tile", left, right, 21));
  const Published out = runBinningRover(events);
  const RoverCounters& k = binningRover().counters();
  LONGS_EQUAL(1, k.pairs_binned);
  LONGS_EQUAL(1, k.pairs_accepted);
  LONGS_EQUAL(0, k.pairs_rejected);
  LONGS_EQUAL(1, out.status.pairs_binned);
  CHECK(k.finished);
  if (heapCounterActive()) LONGS_EQUAL(0, static_cast<long>(out.pipeline_allocs));

  // Ties: the right observation against the plane point of the left one, in full-resolution pixels.
  const auto& l = out.ties.at("tile_L");
  const auto& r = out.ties.at("tile_R");
  std::vector<double> residual_px;
  Vec2 mean_offset = Vec2::Zero();  // a wrong pixel frame would show as a common offset
  double max_x = 0.0;
  for (const auto& [point, lp] : l) {
    const auto it = r.find(point);
    Vec3 ground;
    Vec2 truth;
    if (it == r.end() || !test::planePoint(left, lp, kPlaneZ_m, ground) || !ok(project(right, ground, truth)))
      continue;
    residual_px.push_back((it->second - truth).norm());
    mean_offset += (it->second - truth);
    max_x = std::fmax(max_x, lp.x());
  }
  std::sort(residual_px.begin(), residual_px.end());
  const auto n = static_cast<int32_t>(residual_px.size());
  const double median = n > 0 ? residual_px[residual_px.size() / 2] : 1e9;
  const double p90 = n > 0 ? residual_px[residual_px.size() * 9 / 10] : 1e9;
  if (n > 0) mean_offset /= n;
  // The published models: the full-resolution frame, close to the a-priori (= true) models.
  double model_px = 0.0;
  int32_t models = 0;
  for (const eo_entry_t& e : out.eo.images) {
    if (models >= out.eo.num_images) break;
    ++models;
    CameraModel m;
    const char* field = "";
    CHECK(ok(toCameraModel(e.model, m, field)));
    LONGS_EQUAL(1288, m.width);
    LONGS_EQUAL(968, m.height);
    const CameraModel& truth = e.side == eo_entry_t::SIDE_LEFT ? left : right;
    for (const Vec2& px : {Vec2(100, 500), Vec2(640, 480), Vec2(1200, 900)}) {
      Vec3 ground;
      Vec2 a, b;
      if (!test::planePoint(truth, px, kPlaneZ_m, ground) || !ok(project(m, ground, a))) continue;
      CHECK(ok(project(truth, ground, b)));
      model_px = std::fmax(model_px, (a - b).norm());
    }
  }
  std::printf("\nrover on a 1288x968 tile pair: binned %d, %d ties, against the plane (full resolution) median "
              "%.3f px, 90 %% within %.3f px, largest %.3f px, mean offset (%.3f, %.3f) px; left ties up to x = %.0f px; published models %d, "
              "within %.3f px of the a-priori; heap %llu; JPEG %zu bytes\n",
              static_cast<int>(k.pairs_binned), static_cast<int>(n), median, p90,
              n > 0 ? residual_px.back() : 0.0, mean_offset.x(), mean_offset.y(), max_x, static_cast<int>(models),
              model_px, static_cast<unsigned long long>(out.pipeline_allocs), events.front().data.size());
  CHECK(n >= 30);
  // No common offset: ties left in binned pixels would be off by hundreds of pixels, a pixel frame off by
  // the block centre's (b - 1) / 2 by half a pixel. The spread is the 2x binned matcher's precision: half a
  // binned pixel for most, two for nearly all.
  CHECK(mean_offset.norm() <= 0.2);
  CHECK(median <= 1.0);
  CHECK(p90 <= 4.0);
  CHECK(max_x > 1288 / 2.0);  // ties beyond the binned frame's width: full-resolution coordinates
  LONGS_EQUAL(2, models);
  CHECK(model_px <= 2.0);
}

// One column beyond what binning by kMaxBinning brings within the capacity (areomap-pack --inject
// oversize): refused before decoding, counted under capacity_exceeded and not as binned, with a message
// that says why; the node goes on.
TEST(RoverBinning, FrameBeyondTheLargestBinningIsRefused) {
  const CameraModel left = test::tile(false, 0.0, 0.0), right = test::tile(true, 0.0, 0.0);
  const std::vector<LogEvent> events = injectFaults(packed(renderedPair("tile", left, right, 21)), "oversize:0");
  const Published out = runBinningRover(events);
  const RoverCounters& k = binningRover().counters();
  std::printf("\nrover on a %d-px-wide frame: %s\n", static_cast<int>(kMaxBinnedSourceWidth + 1),
              out.errors.empty() ? "" : out.errors.front().c_str());
  LONGS_EQUAL(0, k.pairs_binned);
  LONGS_EQUAL(0, k.pairs_accepted);
  LONGS_EQUAL(1, k.pairs_rejected);
  LONGS_EQUAL(1, k.rejected_by_cause[static_cast<int>(Status::kCapacityExceeded)]);
  LONGS_EQUAL(1, out.status.rejected_by_cause[rover_status_t::CAUSE_CAPACITY_EXCEEDED]);
  CHECK(k.finished);
  bool said = false;
  for (const std::string& e : out.errors) said = said || e.find("beyond binning by 8") != std::string::npos;
  CHECK(said);
  if (heapCounterActive()) LONGS_EQUAL(0, static_cast<long>(out.pipeline_allocs));
}
