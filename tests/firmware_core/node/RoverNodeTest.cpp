// RoverNode's stream handling without images (builds for the cross targets too): sequence gaps, duplicates,
// reordering, bad messages by cause, status publication, zero heap after start().
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <vector>

#include <malloc.h>

#include <Eigen/Core>

#include "areomap/rover_status_t.hpp"
#include "areomap/site_pose_t.hpp"
#include "areomap/site_t.hpp"
#include "areomap/stereo_pair_t.hpp"
#include "firmware_core/node/RoverNode.hpp"
#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "platform/posix/ArenaJpegDecoder.hpp"
#include "platform/stub/ManualClock.hpp"
#include "platform/stub/MemoryTransport.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

RoverNode g_node;  // ~41 MiB, static as on the rover
uint8_t g_arena[platform::ArenaJpegDecoder::kArenaBytes];
uint8_t g_queue[2 * 1024 * 1024];

std::vector<uint8_t> encodeMarker(int64_t sequence, int8_t kind) {
  stereo_pair_t p{};
  p.sequence = sequence;
  p.kind = kind;
  p.panorama = "unit";
  p.pair_id = static_cast<int32_t>(sequence);
  // A valid CAHV model, so that the missing JPEG is what the node stops at.
  p.left.model.type = camera_model_t::TYPE_CAHV;
  p.left.model.a[0] = 1.0;
  p.left.model.h_px[0] = 512.0;
  p.left.model.h_px[1] = 500.0;
  p.left.model.v_px[0] = 512.0;
  p.left.model.v_px[2] = 500.0;
  p.left.model.linearity = 1.0;
  std::vector<uint8_t> b(static_cast<std::size_t>(p.getEncodedSize()));
  (void)p.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

struct LastStatus {
  rover_status_t status;
  int count = 0;
  static void on(void* ctx, const char*, const uint8_t* data, std::size_t size) {
    auto* self = static_cast<LastStatus*>(ctx);
    if (ok(msgs::decodeMessage(data, size, self->status))) self->count += 1;
  }
};

}  // namespace

// Every test starts the node afresh on a memory transport, the static JPEG arena and a manual clock.
TEST_GROUP(RoverNodeStream) {
  platform::MemoryTransport out{g_queue, sizeof(g_queue)};
  platform::ArenaJpegDecoder jpeg{g_arena, sizeof(g_arena)};
  platform::ManualClock clock{1'700'000'000'000'000, 1'000'000};
  void setup() override {
    CHECK(ok(jpeg.open()));
    RoverOptions options;
    options.log_to_stderr = false;
    g_node.start(out, jpeg, clock, options);
  }
};

// 0, 1, 3 (one missing), 2 (late: reordered), 3 again (duplicate), a truncated message, another type on the
// channel, a pair without images, an unknown kind: each counted under its cause; no heap after start().
TEST(RoverNodeStream, SequencesAndBadMessagesCountedWithoutHeap) {
  LastStatus last;
  CHECK(ok(out.subscribe(channels::kRoverStatus, &LastStatus::on, &last)));

  std::vector<std::vector<uint8_t>> messages;
  for (int64_t s : {0, 1, 3, 2, 3}) messages.push_back(encodeMarker(s, stereo_pair_t::KIND_PAIR));
  std::vector<uint8_t> truncated = encodeMarker(4, stereo_pair_t::KIND_PAIR);
  truncated.resize(truncated.size() - 10);
  messages.push_back(truncated);
  rover_status_t other{};
  std::vector<uint8_t> wrong(static_cast<std::size_t>(other.getEncodedSize()));
  (void)other.encode(wrong.data(), 0, static_cast<int>(wrong.size()));
  messages.push_back(wrong);
  messages.push_back(encodeMarker(5, 7));  // unknown kind
  messages.push_back(encodeMarker(6, stereo_pair_t::KIND_END_OF_PANORAMA));

  HeapAllocationScope scope;
  for (const auto& m : messages) g_node.handleStereoPair(m.data(), m.size());
  g_node.heartbeat();
  const uint64_t allocations = scope.allocations();
  for (int i = 0; i < 100 && ok(out.handle(0)); ++i) {
  }
  const RoverCounters& c = g_node.counters();
  CHECK_EQUAL(0u, allocations);
  CHECK_EQUAL(1, c.sequence_gaps);  // 4 (truncated: its sequence never read)
  CHECK_EQUAL(1, c.duplicates);
  CHECK_EQUAL(1, c.reordered);
  // Pairs 0, 1, 3, 2 carry no JPEG: missing_field; the truncated one, the other type, the unknown kind.
  CHECK_EQUAL(4, c.rejected_by_cause[static_cast<int>(Status::kMissingField)]);
  CHECK_EQUAL(1, c.rejected_by_cause[static_cast<int>(Status::kTruncated)]);
  CHECK_EQUAL(1, c.rejected_by_cause[static_cast<int>(Status::kUnsupported)]);
  CHECK_EQUAL(1, c.rejected_by_cause[static_cast<int>(Status::kInvalidArgument)]);
  CHECK_EQUAL(static_cast<int>(messages.size()), c.pairs_seen);
  CHECK_EQUAL(0, c.pairs_accepted);
  CHECK_TRUE(c.finished);
  // The status on the wire says the same.
  CHECK_TRUE(last.count > 0);
  CHECK_EQUAL(1, last.status.sequence_gaps);
  CHECK_EQUAL(4, last.status.rejected_by_cause[rover_status_t::CAUSE_MISSING_FIELD]);
  CHECK_EQUAL(rover_status_t::STATE_FINISHED, last.status.state);
  // static_bytes is static memory and start-up reserve together (no caller's buffers here).
  CHECK_EQUAL(static_cast<int64_t>(sizeof(RoverNode)) + RoverNode::reservedBytes(), last.status.static_bytes);

  // After the end marker, sequence 0 starts a new stream: not a duplicate.
  const std::vector<uint8_t> again = encodeMarker(0, stereo_pair_t::KIND_PAIR);
  g_node.handleStereoPair(again.data(), again.size());
  CHECK_EQUAL(1, g_node.counters().duplicates);
  CHECK_EQUAL(5, g_node.counters().rejected_by_cause[static_cast<int>(Status::kMissingField)]);
}

// Numbers read from a message before they are used: a negative sequence is rejected (invalid_argument); a
// sequence that jumps by ~2^62 counts its gap without overflowing the counter; an image larger than the
// largest binnable frame or a model of another size is rejected before its JPEG is decoded; no heap.
TEST(RoverNodeStream, SequenceAndSizesCheckedBeforeUse) {
  auto withImage = [](int64_t sequence, int32_t width, int32_t model_width) {
    stereo_pair_t p{};
    std::vector<uint8_t> bytes = encodeMarker(sequence, stereo_pair_t::KIND_PAIR);
    CHECK(ok(msgs::decodeMessage(bytes.data(), bytes.size(), p)));
    p.left.jpeg.assign(16, 0xFF);  // never decoded: the sizes stop it first
    p.left.jpeg_bytes = 16;
    p.left.width_px = width;
    p.left.height_px = 500;
    p.left.model.width_px = model_width;
    p.left.model.height_px = 500;
    std::vector<uint8_t> b(static_cast<std::size_t>(p.getEncodedSize()));
    (void)p.encode(b.data(), 0, static_cast<int>(b.size()));
    return b;
  };
  std::vector<std::vector<uint8_t>> messages;
  messages.push_back(encodeMarker(-3, stereo_pair_t::KIND_PAIR));
  // Beyond what binning by kMaxBinning brings within the capacity (a frame up to that is binned).
  messages.push_back(withImage(0, kMaxBinnedSourceWidth + 1, kMaxBinnedSourceWidth + 1));
  messages.push_back(withImage(1, 800, 1000));
  messages.push_back(encodeMarker(int64_t{1} << 62, stereo_pair_t::KIND_PAIR));
  messages.push_back(encodeMarker(INT64_MAX, stereo_pair_t::KIND_PAIR));

  HeapAllocationScope scope;
  for (const auto& m : messages) g_node.handleStereoPair(m.data(), m.size());
  const uint64_t allocations = scope.allocations();
  const RoverCounters& c = g_node.counters();
  CHECK_EQUAL(0u, allocations);
  // -3: invalid_argument; model of another size: invalid_argument.
  CHECK_EQUAL(2, c.rejected_by_cause[static_cast<int>(Status::kInvalidArgument)]);
  CHECK_EQUAL(1, c.rejected_by_cause[static_cast<int>(Status::kCapacityExceeded)]);
  // The two huge sequences carry no JPEG.
  CHECK_EQUAL(2, c.rejected_by_cause[static_cast<int>(Status::kMissingField)]);
  CHECK_EQUAL(INT32_MAX, c.sequence_gaps);  // saturated, not wrapped negative
  CHECK_EQUAL(0, c.pairs_accepted);
}

// A traverse's site announcements (AREOMAP_SITE) without images: a bad one counted under its cause
// (sites_rejected), the good ones accepted; endOfRun() only after the end marker of the last announced
// site's panorama, not after the first site's; a second site's stream (sequences from 0 again) is not
// counted as duplicates; no heap after start().
TEST(RoverNodeStream, SiteAnnouncementsAndEndOfRun) {
  const auto site = [](int32_t index, const char* panorama) {
    site_t m{};
    m.sequence = index;
    m.traverse = "unit-traverse";
    m.site_id = index == 0 ? "site01" : "site02";
    m.site_index = index;
    m.sites_planned = 2;
    m.panorama = panorama;
    m.has_odometry = index > 0;
    if (index > 0) {
      m.odometry_from = "site01";
      m.delta_m[0] = 10.0;
      m.distance_m = 10.0;
      m.sigma_m[0] = m.sigma_m[1] = m.sigma_m[2] = 0.5;
      m.sigma_heading_deg = 2.0;
    }
    m.is_last = index == 1;
    std::vector<uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
    (void)m.encode(b.data(), 0, static_cast<int>(b.size()));
    return b;
  };
  const auto named = [](int64_t sequence, int8_t kind, const char* panorama) {
    std::vector<uint8_t> b = encodeMarker(sequence, kind);
    stereo_pair_t p;
    CHECK(ok(msgs::decodeMessage(b.data(), b.size(), p)));
    p.panorama = panorama;
    b.resize(static_cast<std::size_t>(p.getEncodedSize()));
    (void)p.encode(b.data(), 0, static_cast<int>(b.size()));
    return b;
  };
  const std::vector<uint8_t> first = site(0, "unit-1"), second = site(1, "unit-2");
  std::vector<uint8_t> truncated = second;
  truncated.resize(truncated.size() / 2);
  const std::vector<uint8_t> pair_a = named(0, stereo_pair_t::KIND_PAIR, "unit-1"),
                             end_a = named(1, stereo_pair_t::KIND_END_OF_PANORAMA, "unit-1"),
                             pair_b = named(0, stereo_pair_t::KIND_PAIR, "unit-2"),
                             end_b = named(1, stereo_pair_t::KIND_END_OF_PANORAMA, "unit-2");
  HeapAllocationScope scope;
  g_node.handleSite(first.data(), first.size());
  g_node.handleStereoPair(pair_a.data(), pair_a.size());
  g_node.handleStereoPair(end_a.data(), end_a.size());
  const bool finished_a = g_node.counters().finished, end_of_run_a = g_node.endOfRun();
  g_node.handleSite(truncated.data(), truncated.size());
  g_node.handleSite(second.data(), second.size());
  g_node.handleStereoPair(pair_b.data(), pair_b.size());
  const bool end_of_run_mid = g_node.endOfRun();
  g_node.handleStereoPair(end_b.data(), end_b.size());
  const uint64_t allocations = scope.allocations();
  const RoverCounters& c = g_node.counters();
  CHECK_EQUAL(0u, allocations);
  CHECK_TRUE(finished_a);
  CHECK_FALSE(end_of_run_a);  // the first site's marker: the traverse goes on
  CHECK_FALSE(end_of_run_mid);
  CHECK_TRUE(g_node.endOfRun());
  CHECK_EQUAL(2, c.sites_announced);
  CHECK_EQUAL(1, c.sites_rejected);
  CHECK_EQUAL(1, c.rejected_by_cause[static_cast<int>(Status::kTruncated)]);
  CHECK_EQUAL(0, c.duplicates);
  CHECK_EQUAL(0, c.sequence_gaps);
  CHECK_EQUAL(2, c.end_markers);
  CHECK_EQUAL(2, c.rejected_by_cause[static_cast<int>(Status::kMissingField)]);  // the pairs carry no JPEG
}

namespace {

// A traverse site announcement: site `index` of `count`, its leg (when index > 0) from the site before.
std::vector<uint8_t> encodeTraverseSite(int32_t index, int32_t count, const double delta_m[3],
                                        double delta_heading_deg, const double sigma_m[3],
                                        double sigma_heading_deg) {
  site_t m{};
  m.sequence = index;
  m.traverse = "odometry-traverse";
  char id[16];
  std::snprintf(id, sizeof(id), "site%02d", static_cast<int>(index + 1));
  m.site_id = id;
  m.site_index = index;
  m.sites_planned = count;
  m.panorama = std::string("pano-") + id;
  m.has_odometry = index > 0;
  if (index > 0) {
    std::snprintf(id, sizeof(id), "site%02d", static_cast<int>(index));
    m.odometry_from = id;
    for (int k = 0; k < 3; ++k) {
      m.delta_m[k] = delta_m[k];
      m.sigma_m[k] = sigma_m[k];
    }
    m.delta_heading_deg = delta_heading_deg;
    m.distance_m = std::sqrt(delta_m[0] * delta_m[0] + delta_m[1] * delta_m[1]);
    m.sigma_heading_deg = sigma_heading_deg;
  }
  m.is_last = index == count - 1;
  std::vector<uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  (void)m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

struct SitePoses {
  site_pose_t last[8];
  int count = 0;
  static void on(void* ctx, const char*, const uint8_t* data, std::size_t size) {
    auto* self = static_cast<SitePoses*>(ctx);
    site_pose_t m;
    if (!ok(msgs::decodeMessage(data, size, m))) return;
    if (m.site_index >= 0 && m.site_index < 8) self->last[m.site_index] = m;
    self->count += 1;
  }
};

Eigen::Matrix3d rz(double deg) {
  const double h = deg * 3.14159265358979323846 / 180.0;
  Eigen::Matrix3d r;
  r << std::cos(h), -std::sin(h), 0.0, std::sin(h), std::cos(h), 0.0, 0.0, 0.0, 1.0;
  return r;
}

Eigen::Matrix3d skewOf(const Eigen::Vector3d& v) {
  Eigen::Matrix3d s;
  s << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return s;
}

}  // namespace

// Three sites announced with their odometry legs, each panorama without images: after each, AREOMAP_SITE_POSE
// for every site of the window (1 + 2 + 3 messages); the last sites' poses are the odometry chained, their
// covariance the legs' propagated to first order (computed here independently: position sigmas along the
// previous site's axes, the previous site's rotation swinging the leg), status ODOMETRY; no heap.
TEST(RoverNodeStream, SitePosesFromOdometryWithTheirCovariance) {
  const double d1[3] = {12.0, 3.0, 0.2}, d2[3] = {15.0, -4.0, -0.1};
  const double s1[3] = {0.6, 0.5, 0.1}, s2[3] = {0.8, 0.7, 0.15};
  const double h1 = 30.0, h2 = -20.0, sh = 2.0;
  const std::vector<uint8_t> sites[3] = {encodeTraverseSite(0, 3, d1, 0.0, s1, sh),
                                         encodeTraverseSite(1, 3, d1, h1, s1, sh),
                                         encodeTraverseSite(2, 3, d2, h2, s2, sh)};
  std::vector<uint8_t> ends[3];
  for (int k = 0; k < 3; ++k) {
    stereo_pair_t p;
    const std::vector<uint8_t> marker = encodeMarker(0, stereo_pair_t::KIND_END_OF_PANORAMA);
    CHECK(ok(msgs::decodeMessage(marker.data(), marker.size(), p)));
    site_t announced;
    CHECK(ok(msgs::decodeMessage(sites[k].data(), sites[k].size(), announced)));
    p.panorama = announced.panorama;
    ends[k].resize(static_cast<std::size_t>(p.getEncodedSize()));
    (void)p.encode(ends[k].data(), 0, static_cast<int>(ends[k].size()));
  }
  SitePoses poses;
  CHECK(ok(out.subscribe(channels::kSitePose, SitePoses::on, &poses)));
  HeapAllocationScope scope;
  for (int k = 0; k < 3; ++k) {
    g_node.handleSite(sites[k].data(), sites[k].size());
    g_node.handleStereoPair(ends[k].data(), ends[k].size());
  }
  const uint64_t allocations = scope.allocations();
  for (int i = 0; i < 200 && ok(out.handle(0)); ++i) {
  }
  CHECK_EQUAL(0u, allocations);
  CHECK_EQUAL(6, poses.count);
  CHECK_EQUAL(site_pose_t::STATUS_DATUM, poses.last[0].status);
  CHECK_EQUAL(site_pose_t::STATUS_ODOMETRY, poses.last[2].status);
  // The odometry chain and its first-order covariance.
  const Eigen::Vector3d leg1(d1[0], d1[1], d1[2]), leg2(d2[0], d2[1], d2[2]);
  const Eigen::Matrix3d q1 = rz(h1), q2 = rz(h1 + h2);
  const Eigen::Vector3d p1 = leg1, p2 = p1 + q1 * leg2;
  const double level = 1e-3, heading = sh * 3.14159265358979323846 / 180.0;
  const Eigen::Matrix3d rot1 = q1 * Eigen::Vector3d(level * level, level * level, heading * heading).asDiagonal() *
                               q1.transpose();
  const Eigen::Matrix3d cov_p1 = Eigen::Vector3d(s1[0] * s1[0], s1[1] * s1[1], s1[2] * s1[2]).asDiagonal();
  const Eigen::Matrix3d cov_p2 =
      cov_p1 + q1 * Eigen::Vector3d(s2[0] * s2[0], s2[1] * s2[1], s2[2] * s2[2]).asDiagonal() * q1.transpose() +
      skewOf(q1 * leg2) * rot1 * skewOf(q1 * leg2).transpose();
  for (int k = 0; k < 3; ++k) {
    DOUBLES_EQUAL(p2[k], poses.last[2].position_m[k], 1e-6);
    DOUBLES_EQUAL(std::sqrt(cov_p2(k, k)), poses.last[2].sigma_position_m[k], 0.01 * std::sqrt(cov_p2(k, k)));
    DOUBLES_EQUAL(std::sqrt(cov_p1(k, k)), poses.last[1].sigma_position_m[k], 0.01 * std::sqrt(cov_p1(k, k)));
    for (int j = 0; j < 3; ++j) DOUBLES_EQUAL(q2(k, j), poses.last[2].rotation[3 * k + j], 1e-9);
  }
  DOUBLES_EQUAL(h1 + h2, poses.last[2].heading_deg, 1e-9);
  DOUBLES_EQUAL(std::sqrt(2.0) * heading, poses.last[2].sigma_rotation_rad[2], 0.01 * heading);
  DOUBLES_EQUAL(std::hypot(d1[0], d1[1]) + std::hypot(d2[0], d2[1]), poses.last[2].distance_m, 1e-9);
  DOUBLES_EQUAL(0.0, poses.last[0].sigma_position_m[0], 0.0);  // the datum
}

TEST_GROUP(RoverNodeMemory){};

// The heap start() takes is what RoverNode::reservedBytes() states, which the budget counts: measured as the
// growth of the allocator's bytes in use (arena and mapped chunks, glibc's mallinfo2) across the start() of
// a fresh node, it is at most the stated figure and not far below it (the figure is the reserved payload plus
// the allocator's overhead per allocation, so a reserve that grew or a figure that lost a term both fail).
TEST(RoverNodeMemory, StartReservesTheStatedHeapWithinTheBudget) {
  if (AREOMAP_SANITIZER_BUILD) {
    std::printf("SKIP: the sanitizer's allocator keeps its own books\n");
    return;
  }
  // A node of its own (g_node's message buffers were reserved by an earlier start()), on the heap: the test
  // takes its bytes-in-use mark after allocating it.
  std::unique_ptr<RoverNode> node(new RoverNode);
  uint8_t queue[4096];
  platform::MemoryTransport out{queue, sizeof(queue)};
  platform::ArenaJpegDecoder jpeg{g_arena, sizeof(g_arena)};
  platform::ManualClock clock{1'700'000'000'000'000, 1'000'000};
  RoverOptions options;
  options.log_to_stderr = false;
  const struct mallinfo2 before = mallinfo2();
  node->start(out, jpeg, clock, options);
  const struct mallinfo2 after = mallinfo2();
  const int64_t measured = static_cast<int64_t>(after.uordblks + after.hblkhd) -
                           static_cast<int64_t>(before.uordblks + before.hblkhd);
  std::printf(
      "RoverNode::start() heap: %lld bytes measured, %lld stated; static %lld + reserve = %lld of the "
      "%lld-byte budget\n",
      static_cast<long long>(measured), static_cast<long long>(RoverNode::reservedBytes()),
      static_cast<long long>(sizeof(RoverNode)), static_cast<long long>(node->memoryBytes()),
      static_cast<long long>(kStaticMemoryBudgetBytes));
  CHECK_TRUE(measured <= RoverNode::reservedBytes());
  CHECK_TRUE(measured >= RoverNode::reservedBytes() - RoverNode::reservedBytes() / 50);
  CHECK_TRUE(node->memoryBytes() <= static_cast<int64_t>(kStaticMemoryBudgetBytes));
}
