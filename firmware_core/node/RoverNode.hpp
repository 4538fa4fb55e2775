// The rover pipeline: one AREOMAP_STEREO_PAIR message in, per pair: JPEG decode into fixed
// buffers (a frame above the image capacity binned by the smallest integer factor that fits it, up to
// kMaxBinning, while it decodes; its model rescaled exactly: firmware_core/camera/Binning.hpp; counted as
// pairs_binned; ties and models are published in the pixel frame of the frames as sent), tie points and coarse DEM (PanoramaMatcher), inter-stereo ties with the pairs already seen, an
// incremental fast adjustment warm-started from the previous solution (FastAdjuster); a final adjustment at
// the end-of-panorama marker. Publishes AREOMAP_TIEPOINTS, AREOMAP_COARSE_DEM, AREOMAP_EO_SOLUTION and
// AREOMAP_ROVER_STATUS through the output Transport (per pair, and heartbeat() for the 1 Hz status).
//
// Single-threaded: the caller feeds messages (handleStereoPair) and heartbeats from one thread.
// Memory: everything lives in the object (~60 MiB: allocate ONE, statically, e.g. `static RoverNode node;`).
// start() reserves the generated message types' vectors and strings (heap, at start-up only); after it,
// handleStereoPair() and heartbeat() make no heap allocation, throw nothing and never stop on bad data:
// every bad message is counted under its cause (rejected_by_cause[Status]) with a line on stderr.
//
// Sequence numbers of the stream: a jump forward counts the missing messages as gaps (and names them on
// stderr and in last_error), a sequence seen before is a duplicate (dropped), a sequence below the
// highest seen but not seen before is reordered (processed). After the end-of-panorama marker, sequence 0
// starts a new stream and a new panorama.
//
// A traverse (areomap-pack of a traverse.json): each site is announced on AREOMAP_SITE (handleSite) before
// its pairs, which form a panorama of their own (sequences from 0); the node maps site after site, resetting
// the panorama's workspaces (no heap) at the first pair after an end marker. endOfRun() is true after the
// end marker of the last announced site's panorama (or of any panorama when no site was announced).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "areomap/coarse_dem_t.hpp"
#include "areomap/eo_solution_t.hpp"
#include "areomap/rover_status_t.hpp"
#include "areomap/site_pose_t.hpp"
#include "areomap/site_t.hpp"
#include "areomap/stereo_pair_t.hpp"
#include "areomap/tiepoints_t.hpp"
#include "firmware_core/adjust/FastAdjuster.hpp"
#include "firmware_core/adjust/Network.hpp"
#include "firmware_core/adjust/NetworkBuilder.hpp"
#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/Status.hpp"
#include "firmware_core/dem/CoarseDem.hpp"
#include "firmware_core/match/PanoramaMatcher.hpp"
#include "firmware_core/node/RoverTraverse.hpp"
#include "msgs/adapters/MessageAdapters.hpp"
#include "platform/Clock.hpp"
#include "platform/JpegCodec.hpp"
#include "platform/Transport.hpp"

namespace areomap {

// Sequence numbers remembered to tell a duplicate from a reordered message: a panorama has at most
// kMaxPairs pairs + its marker; 4x leaves room for a stream of several panoramas and injected faults.
constexpr int32_t kMaxTrackedSequences = 4 * (kMaxPairs + 1);
// Encoded outgoing message: the EO solution of kMaxImages images (~0.12 MiB) or the tie points of one pair
// (kMaxTiePointsPerMessage x 23 bytes) or a coarse DEM (64 KiB); 1 MiB is ample.
constexpr std::size_t kMaxOutgoingBytes = 1024u * 1024u;
// Observations in one AREOMAP_TIEPOINTS message: one pair's intra (2 x kMaxTiesPerPair) and inter ties;
// more are counted as overflow.
constexpr int32_t kMaxTiePointsPerMessage = kMaxTiePoints;
// Missing sequence numbers named in last_error and on stderr per gap (the count is always exact).
constexpr int32_t kMaxNamedGapSequences = 8;
// Characters of RoverNode::last_error_ (and of the status's last_error, reserved to match).
constexpr int32_t kMaxLastErrorChars = 255;

// Heap that RoverNode::start() reserves for the generated message types, an upper bound of what the allocator
// holds for it from then on (~4.4 MiB): the payload of every vector and string it reserves, plus per
// allocation the allocator's chunk header and 16-byte rounding (< 32 B in glibc), plus a page for each of
// the two JPEG buffers (allocations that large are mapped, in whole pages). A string reserved for n
// characters allocates n + 1; a test measures start() against this figure.
namespace rover_reserve {
constexpr int64_t kStringBytes = kMaxMessageStringChars + 2;  // reserve(chars + 1), plus the NUL
constexpr int64_t kImages = kMaxImages;
constexpr int64_t kTies = kMaxTiePointsPerMessage;
constexpr int64_t kStereoPair =
    3 * kStringBytes + 2 * static_cast<int64_t>(kMaxJpegBytes);  // panorama, stems
constexpr int64_t kTiePoints =
    kStringBytes + kImages * static_cast<int64_t>(sizeof(std::string)) + kImages * kStringBytes +
    kTies * static_cast<int64_t>(sizeof(int32_t) + sizeof(int16_t) + 2 * sizeof(double) + sizeof(int8_t));
constexpr int64_t kCoarseDem = kStringBytes + static_cast<int64_t>(kCoarseDemCells) * kCoarseDemCells *
                                                  static_cast<int64_t>(sizeof(float));
constexpr int64_t kEo =
    kStringBytes + kImages * static_cast<int64_t>(sizeof(eo_entry_t)) + kImages * kStringBytes;
constexpr int64_t kStatus = kMaxLastErrorChars + 2;
constexpr int64_t kSite = 4 * kStringBytes;      // traverse, site id, panorama, odometry_from
constexpr int64_t kSitePose = 3 * kStringBytes;  // traverse, site id, panorama
// stereo pair 5, tie points 1 + 1 + kImages + 5, coarse DEM 2, EO 1 + 1 + kImages, status 1, site 4,
// site pose 3.
constexpr int64_t kAllocations = 5 + (7 + kImages) + 2 + (2 + kImages) + 1 + 4 + 3;
constexpr int64_t kAllocatorBytes = 32 * kAllocations + 2 * 4096;
}  // namespace rover_reserve
constexpr int64_t kRoverStartupReserveBytes =
    rover_reserve::kStereoPair + rover_reserve::kTiePoints + rover_reserve::kCoarseDem + rover_reserve::kEo +
    rover_reserve::kStatus + rover_reserve::kSite + rover_reserve::kSitePose + rover_reserve::kAllocatorBytes;

enum class RoverStage : uint8_t {
  kDecode = 0,
  kFeatures = 1,
  kMatch = 2,
  kDem = 3,
  kAdjust = 4,
  kPublish = 5
};

struct RoverCounters {
  int32_t pairs_seen = 0;
  int32_t pairs_accepted = 0;
  int32_t pairs_rejected = 0;
  int32_t pairs_binned = 0;  // pairs decoded binned (frames above the image capacity), accepted or not
  int32_t rejected_by_cause[static_cast<int32_t>(Status::kCount)] = {};
  int32_t sequence_gaps = 0;
  int32_t duplicates = 0;
  int32_t reordered = 0;
  int32_t no_texture_pairs = 0;  // pairs without any tie (also in rejected_by_cause[kNoTexture])
  int32_t adjustments = 0;
  int32_t adjust_failures = 0;
  int32_t tie_overflow = 0;  // observations not sent for lack of message room
  int32_t publish_failures = 0;
  int32_t end_markers = 0;
  int32_t sites_announced = 0;  // AREOMAP_SITE announcements accepted
  int32_t sites_rejected = 0;   // ... refused (also in rejected_by_cause)
  int32_t site_poses_published = 0;  // AREOMAP_SITE_POSE messages
  double stage_seconds[8] = {};
  double panorama_seconds = 0.0;  // first pair message to the final EO
  double traverse_seconds = 0.0;  // the site-pose steps after each site (registration, matching, adjustment)
  int32_t last_sweeps = 0;
  double last_rms_px = 0.0;
  // The rig model of the last adjustment (firmware_core/adjust/RigShape.hpp): the FIDO model when the
  // a-priori cameras do not turn about one point, and Eq. 3's fit RMS that decided it.
  bool fido_model = false;
  double rig_fit_rms_m = 0.0;
  bool finished = false;
};

struct RoverOptions {
  FastAdjustOptions adjust;  // incremental and final adjustments
  bool log_to_stderr = true;
};

class RoverNode {
 public:
  // Prepares the message objects (heap at start-up), resets the panorama. `out` receives every publication.
  void start(platform::Transport& out, platform::JpegCodec& codec, const platform::Clock& clock,
             const RoverOptions& options);

  // One AREOMAP_STEREO_PAIR message (the bytes as received). Never fails: problems are counted.
  void handleStereoPair(const uint8_t* data, std::size_t size);
  // One AREOMAP_SITE message: a traverse site announced before its pairs. Never fails: a bad one is counted
  // (sites_rejected and rejected_by_cause) with a line on stderr.
  void handleSite(const uint8_t* data, std::size_t size);
  // True after the end marker of the last announced site's panorama, or of any panorama when no site was
  // announced (a single-panorama stream): what --exit-at-end waits for.
  bool endOfRun() const;
  // Publishes AREOMAP_ROVER_STATUS now (the 1 Hz heartbeat).
  void heartbeat();
  // Heap figures to report: allocations of the pipeline thread after start-up and of the whole process.
  void setHeapCounts(int64_t pipeline_after_init, int64_t process_after_init) {
    heap_pipeline_ = pipeline_after_init;
    heap_process_ = process_after_init;
  }
  int64_t heapPipeline() const { return heap_pipeline_; }
  int64_t heapProcess() const { return heap_process_; }
  // Static buffers of the caller (transport slots, JPEG arena) to include in staticBytes().
  void setExtraStaticBytes(int64_t bytes) { extra_static_bytes_ = bytes; }
  // Statically allocated bytes (this object and the caller's buffers).
  int64_t staticBytes() const;
  // Heap reserved once by start() for the generated message types' vectors and strings (an upper bound).
  static constexpr int64_t reservedBytes() { return kRoverStartupReserveBytes; }
  // The memory the rover holds from start-up on, static and start-up reserve together: what the 72 MiB
  // budget covers, and static_bytes in AREOMAP_ROVER_STATUS.
  int64_t memoryBytes() const { return staticBytes() + reservedBytes(); }

  const RoverCounters& counters() const { return counters_; }
  const Network& network() const { return net_; }
  const NetworkBuilder& networkBuilder() const { return network_builder_; }
  const char* stemOfImage(int32_t net_image) const { return stem_of_image_[net_image]; }
  const char* lastError() const { return last_error_; }
  const RoverTraverse& traverse() const { return traverse_; }

 private:
  void resetPanorama();
  void reject(Status cause, int64_t sequence, int32_t pair_id, const char* what);
  // kOk: process it; kCorruptData: duplicate, drop.
  bool trackSequence(int64_t sequence);
  // reject(), then the status published.
  void rejectAndPublish(Status cause, int64_t sequence, int32_t pair_id, const char* what);
  // One pair of the panorama, then its steps in the order they run. A step that returns false has rejected
  // the pair (counted under its cause, the status published).
  void processPair(int64_t sequence);
  void openPanorama();
  bool workspaceHasRoom(int64_t sequence, int32_t pair_id);
  bool readModels(int64_t sequence, int32_t pair_id, CameraModel models[2]);
  bool rigValuesFinite(int64_t sequence, int32_t pair_id);
  bool imageSizesFit(int64_t sequence, int32_t pair_id);
  // Decodes both images, binned by the pair's factor when a frame exceeds the capacity (binning_ set).
  bool decodeImages(int64_t sequence, int32_t pair_id, int32_t w[2], int32_t h[2]);
  bool findSol(int64_t sequence, int32_t pair_id, int32_t& sol_index);
  bool matchPair(int64_t sequence, int32_t pair_id, const CameraModel models[2], const int32_t w[2],
                 const int32_t h[2], int32_t& first_observation);
  bool enterNetwork(int64_t sequence, int32_t pair_id, int32_t sol_index, const CameraModel models[2]);
  void setRigFromMessage(int32_t sol_index);
  void finishPanorama();
  Status decodeSide(const stereo_image_t& side, int32_t bin, uint8_t* pixels, int32_t& width, int32_t& height);
  void chooseRigModel();
  Status adjustNow(bool final_solve);
  // Publications (RoverNodePublishing.cpp).
  void publishTiePoints(int32_t pair_id, int32_t first_observation);
  void publishDem(int32_t pair_id);
  void publishEo(int32_t pair_id, bool final_solution);
  void publishStatus();
  void publishSitePoses();
  // The announced site's panorama ended: the site into the traverse adjustment, its poses published.
  void finishTraverseSite(bool mapped);
  void keepForTraverse(int32_t width, int32_t height);
  template <class Message>
  void publishMessage(const char* channel, Message& message);
  double now() const;

  platform::Transport* out_ = nullptr;
  platform::JpegCodec* codec_ = nullptr;
  const platform::Clock* clock_ = nullptr;
  RoverOptions options_;

  // Workspaces (static with the object).
  uint8_t left_pixels_[kMaxImagePixels];
  uint8_t right_pixels_[kMaxImagePixels];
  PanoramaMatcher matcher_;
  CoarseDem coarse_dem_;  // the last pair's, made by the matcher and published
  NetworkBuilder network_builder_;
  Network net_;
  FastAdjuster adjuster_;
  RoverTraverse traverse_;
  uint8_t out_buffer_[kMaxOutgoingBytes];

  // Messages (vectors reserved at start-up).
  stereo_pair_t in_;
  tiepoints_t tiepoints_;
  coarse_dem_t dem_;
  eo_solution_t eo_;
  rover_status_t status_;
  site_t site_in_;
  site_pose_t site_pose_;
  int64_t extra_static_bytes_ = 0;

  // Traverse state: the last site announced (its panorama name, and whether it is the traverse's last).
  char site_panorama_[kMaxMessageStringChars + 1] = {0};
  char ended_panorama_[kMaxMessageStringChars + 1] = {0};  // named by the last end-of-panorama marker
  bool site_announced_ = false;
  bool last_site_announced_ = false;

  // Panorama state.
  char panorama_[kMaxMessageStringChars + 1] = {0};
  char stem_of_matcher_image_[kMaxImages][kMaxMessageStringChars + 1] = {};
  char stem_of_image_[kMaxImages][kMaxMessageStringChars + 1] = {};
  int32_t pair_id_of_image_[kMaxImages] = {};
  // Binning of the pair being processed (1: none), and per image the factor and the full-resolution size:
  // ties and models are published in the pixel frame of the frames as sent.
  int32_t binning_ = 1;
  int32_t binning_of_matcher_image_[kMaxImages] = {};
  int32_t binning_of_image_[kMaxImages] = {};
  int32_t full_size_of_image_[kMaxImages][2] = {};
  int32_t sols_[kMaxSols] = {};
  int32_t sol_count_ = 0;
  bool workspace_full_ = false;  // the matcher's point or observation list ran full: later pairs rejected
  bool panorama_open_ = false;
  double panorama_start_s_ = 0.0;

  // Stream state.
  int64_t sequences_[kMaxTrackedSequences] = {};
  int32_t sequence_count_ = 0;
  int32_t sequence_head_ = 0;
  int64_t highest_sequence_ = -1;

  RoverCounters counters_;
  int64_t heap_pipeline_ = -1;
  int64_t heap_process_ = -1;
  int64_t seq_tiepoints_ = 0, seq_dem_ = 0, seq_eo_ = 0, seq_status_ = 0, seq_site_pose_ = 0;
  char last_error_[kMaxLastErrorChars + 1] = {0};
};

// The rover's share of the budget (Capacities.hpp: 64 MiB for the panorama, 8 MiB for the traverse); the
// node program checks the whole, its own buffers included.
static_assert(sizeof(RoverTraverse) <= kTraverseMemoryBudgetBytes, "the traverse exceeds its 8 MiB budget");
static_assert(sizeof(RoverNode) + kRoverStartupReserveBytes <= kStaticMemoryBudgetBytes,
              "RoverNode and its start-up reserve exceed the 72 MiB budget");

}  // namespace areomap
