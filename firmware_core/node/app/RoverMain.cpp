// areomap-rover --lcm URL: the rover node. Two threads:
//   transport thread (main): LCM (udpm://, memq://) or the heap-free log replay (file://), copies every
//     AREOMAP_STEREO_PAIR message into the inbox ring, publishes what the pipeline put into the outbox;
//   pipeline thread: takes messages from the inbox and runs RoverNode (decode, ties, DEM, adjustment),
//     publishes through the outbox; a status after every pair and every --heartbeat-s seconds when idle.
//   While the pipeline is busy (a navcam pair takes ~2 s), the transport thread re-sends the last status
//   with a fresh utime every --heartbeat-s seconds; it numbers all statuses in one series.
// All buffers are static. heap_allocs_after_init = the pipeline thread's allocations after start-up
// (heapAllocationCountThisThread); the whole process's count (LCM's receive thread included) is printed
// at exit beside it.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <thread>

#include <unistd.h>

#include "firmware_core/node/ByteRing.hpp"
#include "firmware_core/node/RoverNode.hpp"
#include "msgs/Channels.hpp"
#include "platform/TransportUrl.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "platform/posix/ArenaJpegDecoder.hpp"
#include "platform/posix/LcmLogReplay.hpp"
#include "platform/posix/PosixClock.hpp"
#ifndef AREOMAP_NO_LCM_RUNTIME
#include "platform/posix/LcmTransport.hpp"
#endif

namespace {

using areomap::Status;

// Inbox: the largest stereo pair the rover accepts (kMaxStereoPairMessageBytes, ~4.0 MiB) in a ring record,
// two deep: the pipeline decodes the record in hand in place while the next one is copied in. A longer
// burst waits where the sender's transport keeps it (a file:// replay is read only when there is room; a
// udpm stream in the socket's receive buffer, recv_buf_size in the URL), not in static memory.
constexpr std::size_t kInboxDepth = 2;
constexpr std::size_t kInboxBytes =
    kInboxDepth * areomap::ByteRing::recordBytes(areomap::kMaxStereoPairMessageBytes);
constexpr std::size_t kOutboxBytes = 2u * 1024u * 1024u;
constexpr std::size_t kReplayBufferBytes = 2u * areomap::kMaxJpegBytes + 64u * 1024u;
constexpr int32_t kHandleTimeoutMs = 20;

areomap::RoverNode g_node;
uint8_t g_inbox_storage[kInboxBytes];
uint8_t g_outbox_storage[kOutboxBytes];
uint8_t g_replay_buffer[kReplayBufferBytes];
uint8_t g_jpeg_arena[areomap::platform::ArenaJpegDecoder::kArenaBytes];

constexpr std::size_t kStaticBytes = sizeof(areomap::RoverNode) + kInboxBytes + kOutboxBytes +
                                     kReplayBufferBytes + areomap::platform::ArenaJpegDecoder::kArenaBytes;
static_assert(kStaticBytes - sizeof(areomap::RoverTraverse) +
                      static_cast<std::size_t>(areomap::kRoverStartupReserveBytes) <=
                  areomap::kPanoramaMemoryBudgetBytes,
              "the rover's panorama pipeline exceeds its 64 MiB share of the budget");
static_assert(kStaticBytes + static_cast<std::size_t>(areomap::kRoverStartupReserveBytes) <=
                  areomap::kStaticMemoryBudgetBytes,
              "the rover's static memory and start-up reserve exceed its 72 MiB budget");

// The 1 Hz heartbeat while the pipeline is busy with a pair (a matcher call takes seconds): the transport
// thread re-publishes the last status with a fresh utime. It numbers every AREOMAP_ROVER_STATUS it sends
// (the pipeline's and its own) in one series, so the sequence has no gaps and no repeats.
constexpr std::size_t kMaxStatusBytes = 4096;  // an encoded rover_status_t is < 1 KiB (last_error <= 256)
constexpr uint8_t kStatusTag = 3;              // index of AREOMAP_ROVER_STATUS in kChannels
uint8_t g_last_status[kMaxStatusBytes];
std::size_t g_last_status_bytes = 0;
int64_t g_last_status_us = 0;
int64_t g_status_sequence = 0;

// Every channel the pipeline publishes on: an outbox record carries its index (a publish on any other channel
// is refused, never sent under another channel's name).
const char* const kChannels[] = {areomap::channels::kTiePoints, areomap::channels::kEoSolution,
                                 areomap::channels::kCoarseDem, areomap::channels::kRoverStatus,
                                 areomap::channels::kSitePose};
constexpr uint8_t kChannelCount = sizeof(kChannels) / sizeof(kChannels[0]);

std::mutex g_mutex;
std::condition_variable g_wake;
areomap::ByteRing g_inbox(g_inbox_storage, kInboxBytes);
areomap::ByteRing g_outbox(g_outbox_storage, kOutboxBytes);
bool g_input_done = false;
std::atomic<bool> g_stop{false};
std::atomic<bool> g_pipeline_done{false};  // set by the pipeline thread as its last act
std::atomic<bool> g_finished{
    false};  // set by the pipeline thread after the final EO (read by the transport thread)
uint64_t g_inbox_refused = 0;
uint64_t g_inbox_waits = 0;          // messages that waited for room in the inbox (back-pressure)
std::size_t g_inbox_peak_bytes = 0;  // the inbox's highest fill

// The pipeline's Transport: encoded messages go into the outbox (copied, no heap).
class OutboxTransport final : public areomap::platform::Transport {
 public:
  Status publish(const char* channel, const uint8_t* data, std::size_t size) override {
    uint8_t tag = kChannelCount;
    for (uint8_t i = 0; i < kChannelCount; ++i) {
      if (std::strcmp(channel, kChannels[i]) == 0) tag = i;
    }
    if (tag == kChannelCount) return Status::kInvalidArgument;
    std::lock_guard<std::mutex> lock(g_mutex);
    return g_outbox.push(tag, data, size) ? Status::kOk : Status::kCapacityExceeded;
  }
  Status subscribe(const char*, areomap::platform::MessageHandler, void*) override {
    return Status::kUnsupported;
  }
  Status handle(int32_t) override { return Status::kTimeout; }
};

// Inbox record tags: what the pipeline hands the record to.
constexpr uint8_t kTagStereoPair = 0;
constexpr uint8_t kTagSite = 1;

void toInbox(uint8_t tag, const uint8_t* data, std::size_t size) {
  // Back-pressure: wait for room rather than drop (a log replay waits; LCM keeps buffering meanwhile).
  std::unique_lock<std::mutex> lock(g_mutex);
  bool waited = false;
  while (!g_inbox.push(tag, data, size)) {
    if (g_inbox.records() == 0 || g_stop.load()) {
      g_inbox_refused += 1;  // larger than the whole inbox
      std::fprintf(stderr, "areomap-rover: a %zu-byte message is larger than the inbox, dropped\n", size);
      return;
    }
    g_wake.notify_all();
    g_wake.wait_for(lock, std::chrono::milliseconds(10));
    waited = true;
  }
  if (waited) g_inbox_waits += 1;
  if (g_inbox.usedBytes() > g_inbox_peak_bytes) g_inbox_peak_bytes = g_inbox.usedBytes();
  g_wake.notify_all();
}

void onStereoPair(void*, const char*, const uint8_t* data, std::size_t size) {
  toInbox(kTagStereoPair, data, size);
}

// A traverse's site announcement: through the inbox too, so that it is handled in stream order.
void onSite(void*, const char*, const uint8_t* data, std::size_t size) {
  toInbox(kTagSite, data, size);
}

struct Options {
  const char* lcm_url = nullptr;
  const char* publish_url = nullptr;
  double heartbeat_s = 1.0;
  bool exit_at_end = false;
  bool quiet = false;
  double max_seconds = 0.0;
};

constexpr const char* kUsage =
    "usage: areomap-rover --lcm URL [--publish URL] [--exit-at-end] [--heartbeat-s S] [--max-seconds S] "
    "[--quiet]\n"
    "\n"
    "The rover node: subscribes to AREOMAP_STEREO_PAIR on URL (udpm://GROUP:PORT?... live, file:///path.lcm\n"
    "replay as fast as the pipeline takes it, memq://), and for each pair: JPEG decode into fixed buffers, "
    "tie\n"
    "points, coarse DEM, inter-stereo ties with the pairs already seen, an incremental fast adjustment\n"
    "warm-started from the previous solution; a final adjustment at the end-of-panorama marker. A "
    "traverse's\n"
    "sites (AREOMAP_SITE announcements, each before its pairs) are mapped one after the other. Publishes\n"
    "AREOMAP_TIEPOINTS, AREOMAP_COARSE_DEM, AREOMAP_EO_SOLUTION, AREOMAP_ROVER_STATUS (per pair and every\n"
    "--heartbeat-s seconds, default 1).\n"
    "\n"
    "  --publish URL    where results go (default: the --lcm URL when it is udpm:// or memq://; nowhere for "
    "a\n"
    "                   file:// replay unless given)\n"
    "  --exit-at-end    exit after the end-of-panorama marker (always at the end of a file:// log); in a\n"
    "                   traverse (sites announced on AREOMAP_SITE) after the last site's marker\n"
    "  --max-seconds S  exit after S seconds (0 = no limit)\n"
    "  --quiet          no per-pair lines on stderr\n"
    "\n"
    "heap_allocs_after_init in the status = heap allocations of the pipeline thread after start-up (0 when\n"
    "all is well); the whole-process count is printed at exit.\n"
    "\n"
    "SIGINT or SIGTERM stops after the pair in hand (exit 0), or after 3 s without it (exit 1); a process\n"
    "stuck elsewhere exits 6 s after the signal, and a second signal exits at once (exit 1).\n"
    "Exit: 0 ok, 2 usage error, 1 other error.\n";

int usageError(const char* what) {
  std::fprintf(stderr, "areomap-rover: %s\n%s", what, kUsage);
  return 2;
}

bool parseNumber(const char* text, double& out) {
  char* end = nullptr;
  out = std::strtod(text, &end);
  return end != text && *end == '\0';
}

// Stopping (SIGINT, SIGTERM, --max-seconds) ends the process within seconds whatever it is doing:
//  - the transport loop sees g_stop within kHandleTimeoutMs and the pipeline stops after the pair in hand;
//  - a pair in hand for longer than kStopGraceUs (seconds natively, tens of seconds under qemu) is abandoned:
//    the process exits with status 1 without it (std::_Exit, the pipeline thread still running);
//  - the handler arms a watchdog (alarm) for a process stuck anywhere else, e.g. the aarch64 rover under
//    qemu with the wrong sysroot (`-L /usr/aarch64-linux-gnu`: glibc's loader and libc of two builds, the
//    first pthread_create never returns; toolchains/README.md), which otherwise ran on after SIGTERM;
//  - a second signal exits at once.
constexpr int64_t kStopGraceUs = 3'000'000;
constexpr unsigned kStopWatchdogSeconds = 6;  // > kStopGraceUs: the grace path exits first

void writeStderr(const char* text) {  // async-signal-safe; a short line goes out in one write
  if (write(STDERR_FILENO, text, std::strlen(text)) < 0) return;
}

void onSignal(int) {
  if (g_stop.exchange(true)) {
    writeStderr("areomap-rover: second stop signal, exiting now\n");
    _exit(1);
  }
  alarm(kStopWatchdogSeconds);
}

void onStopWatchdog(int) {
  writeStderr("areomap-rover: a stop signal was not honoured within the watchdog time (stuck), exiting\n");
  _exit(1);
}

void putInt64(uint8_t* at, int64_t value) {
  const auto v = static_cast<uint64_t>(value);
  for (int i = 0; i < 8; ++i) at[i] = static_cast<uint8_t>(v >> (56 - 8 * i));
}

// Publishes a status: the bytes after the fingerprint are utime (8) and sequence (8), rewritten here.
void publishStatus(areomap::platform::Transport* output, const areomap::platform::Clock& clock) {
  if (g_last_status_bytes < 24) return;
  putInt64(g_last_status + 8, clock.wallUtime());
  putInt64(g_last_status + 16, g_status_sequence++);
  g_last_status_us = clock.monotonicUtime();
  if (output != nullptr) (void)output->publish(kChannels[kStatusTag], g_last_status, g_last_status_bytes);
}

// Outbox -> LCM (the transport thread only).
void drainOutbox(areomap::platform::Transport* output, const areomap::platform::Clock& clock) {
  for (;;) {
    uint8_t tag = 0;
    const uint8_t* data = nullptr;
    std::size_t size = 0;
    std::unique_lock<std::mutex> lock(g_mutex);
    if (!g_outbox.front(tag, data, size)) break;
    if (tag == kStatusTag && size <= kMaxStatusBytes) {
      std::memcpy(g_last_status, data, size);
      g_last_status_bytes = size;
      publishStatus(output, clock);
    } else if (output != nullptr) {
      (void)output->publish(kChannels[tag], data, size);
    }
    g_outbox.pop();
  }
}

void pipelineLoop(const Options& options, const areomap::platform::Clock& clock,
                  areomap::platform::ArenaJpegDecoder& jpeg) {
  // Start-up of this thread, before its heap mark: libjpeg-turbo's per-thread SIMD detection (3 heap
  // allocations on 64-bit ARM at the first decode otherwise; ArenaJpegDecoder.cpp).
  if (!areomap::ok(jpeg.warmUpThisThread())) {
    std::fprintf(stderr, "areomap-rover: the JPEG warm-up decode failed on the pipeline thread\n");
  }
  (void)areomap::heapTraceArmThisThread();  // AREOMAP_HEAP_TRACE=1: the stacks of later allocations, at exit
  const uint64_t allocs_thread_start = areomap::heapAllocationCountThisThread();
  const uint64_t allocs_process_start = areomap::heapAllocationCount();
  int64_t next_heartbeat = clock.monotonicUtime() + static_cast<int64_t>(options.heartbeat_s * 1e6);
  bool finished_reported = false;
  for (;;) {
    std::size_t size = 0;
    const uint8_t* message = nullptr;
    bool have = false;
    bool done = false;
    uint8_t tag = 0;
    {
      std::unique_lock<std::mutex> lock(g_mutex);
      if (g_inbox.records() == 0 && !g_input_done && !g_stop.load()) {
        g_wake.wait_for(lock, std::chrono::milliseconds(50));
      }
      // A signal stops after the message in hand; the end of the input lets the inbox drain first.
      have = !g_stop.load() && g_inbox.front(tag, message, size);
      done = g_stop.load() || (g_input_done && g_inbox.records() == 0);
    }
    if (have) {
      // Processed in place: the record stays in the ring (push never overwrites it) until popped here.
      if (tag == kTagSite) {
        g_node.handleSite(message, size);
      } else {
        g_node.handleStereoPair(message, size);
      }
      std::lock_guard<std::mutex> lock(g_mutex);
      g_inbox.pop();
      g_wake.notify_all();
      done = false;
    }
    g_node.setHeapCounts(static_cast<int64_t>(areomap::heapAllocationCountThisThread() - allocs_thread_start),
                         static_cast<int64_t>(areomap::heapAllocationCount() - allocs_process_start));
    const int64_t now = clock.monotonicUtime();
    if (now >= next_heartbeat) {
      g_node.heartbeat();
      next_heartbeat = now + static_cast<int64_t>(options.heartbeat_s * 1e6);
    }
    if (g_node.endOfRun() && !finished_reported) {
      finished_reported = true;
      g_finished.store(true);
      if (options.exit_at_end) done = true;
    }
    if (done && !have) break;
  }
  g_node.heartbeat();
  g_pipeline_done.store(true);
}

// Waits for the pipeline thread to end, draining the outbox; false when a stop request is older than
// kStopGraceUs and the pipeline is still busy (the pair in hand is abandoned).
bool awaitPipeline(areomap::platform::Transport* output, const areomap::platform::Clock& clock) {
  int64_t stop_since = -1;
  while (!g_pipeline_done.load()) {
    drainOutbox(output, clock);
    if (g_stop.load()) {
      {
        std::lock_guard<std::mutex> lock(g_mutex);
        g_input_done = true;
        g_wake.notify_all();
      }
      const int64_t now = clock.monotonicUtime();
      if (stop_since < 0) stop_since = now;
      if (now - stop_since > kStopGraceUs) return false;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(kHandleTimeoutMs));
  }
  return true;
}

// The command line into `options`; -1 when the node is to run, else the exit code (0 for --help, 2 for a
// usage error, with the message).
int parseOptions(int argc, char** argv, Options& options) {
  for (int i = 1; i < argc; ++i) {
    const char* a = argv[i];
    auto value = [&](const char* name) -> const char* {
      if (i + 1 >= argc) return nullptr;
      (void)name;
      return argv[++i];
    };
    if (std::strcmp(a, "--help") == 0 || std::strcmp(a, "-h") == 0) {
      std::fputs(kUsage, stdout);
      return 0;
    } else if (std::strcmp(a, "--lcm") == 0) {
      if ((options.lcm_url = value(a)) == nullptr) return usageError("--lcm needs a URL");
    } else if (std::strcmp(a, "--publish") == 0) {
      if ((options.publish_url = value(a)) == nullptr) return usageError("--publish needs a URL");
    } else if (std::strcmp(a, "--heartbeat-s") == 0) {
      const char* v = value(a);
      if (v == nullptr || !parseNumber(v, options.heartbeat_s) || options.heartbeat_s <= 0.0)
        return usageError("--heartbeat-s needs a positive number");
    } else if (std::strcmp(a, "--max-seconds") == 0) {
      const char* v = value(a);
      if (v == nullptr || !parseNumber(v, options.max_seconds) || options.max_seconds < 0.0)
        return usageError("--max-seconds needs a number >= 0");
    } else if (std::strcmp(a, "--exit-at-end") == 0) {
      options.exit_at_end = true;
    } else if (std::strcmp(a, "--quiet") == 0) {
      options.quiet = true;
    } else {
      char what[300];
      std::snprintf(what, sizeof(what), "unknown argument '%s'", a);
      return usageError(what);
    }
  }
  if (options.lcm_url == nullptr) return usageError("--lcm URL is required");
  return -1;
}

// The node's input (a file:// log replayed from a static buffer, or LCM) and output (LCM, or nowhere).
struct Transports {
  areomap::platform::LcmLogReplay log{g_replay_buffer, sizeof(g_replay_buffer)};
#ifndef AREOMAP_NO_LCM_RUNTIME
  areomap::platform::LcmTransport lcm_in;
  areomap::platform::LcmTransport lcm_out;
#endif
  areomap::platform::Transport* input = nullptr;
  areomap::platform::Transport* output = nullptr;
};

// Opens the input and output and subscribes to the stereo pairs; false (the reason on stderr) when it cannot.
bool openTransports(const Options& options, bool replay, Transports& t) {
  if (replay) {
    if (!areomap::ok(t.log.open(options.lcm_url))) {
      std::fprintf(stderr, "areomap-rover: %s: cannot read the log\n", options.lcm_url);
      return false;
    }
    t.input = &t.log;
  } else {
#ifndef AREOMAP_NO_LCM_RUNTIME
    if (!areomap::ok(t.lcm_in.open(options.lcm_url))) {
      std::fprintf(stderr, "areomap-rover: %s: LCM cannot open this URL (no multicast route?)\n",
                   options.lcm_url);
      return false;
    }
    t.input = &t.lcm_in;
    t.output = &t.lcm_in;
#else
    std::fprintf(stderr, "areomap-rover: %s: this build has no LCM runtime; use a file:// log\n",
                 options.lcm_url);
    return false;
#endif
  }
  if (options.publish_url != nullptr) {
#ifndef AREOMAP_NO_LCM_RUNTIME
    if (!areomap::ok(t.lcm_out.open(options.publish_url))) {
      std::fprintf(stderr, "areomap-rover: %s: LCM cannot open the publish URL\n", options.publish_url);
      return false;
    }
    t.output = &t.lcm_out;
#else
    std::fprintf(stderr, "areomap-rover: --publish: this build has no LCM runtime\n");
    return false;
#endif
  }
  if (!areomap::ok(t.input->subscribe(areomap::channels::kStereoPair, onStereoPair, nullptr))) {
    std::fprintf(stderr, "areomap-rover: cannot subscribe to %s\n", areomap::channels::kStereoPair);
    return false;
  }
  if (!areomap::ok(t.input->subscribe(areomap::channels::kSite, onSite, nullptr))) {
    std::fprintf(stderr, "areomap-rover: cannot subscribe to %s\n", areomap::channels::kSite);
    return false;
  }
  return true;
}

// The transport thread's loop: input into the inbox, the outbox out, the status heartbeat, the stop and
// the end of the input; joins the pipeline thread. True when the input failed (a log that cannot be read).
bool transportLoop(const Options& options, bool replay, Transports& t, const areomap::platform::Clock& clock,
                   std::thread& pipeline) {
  const int64_t start_us = clock.monotonicUtime();
  bool input_failed = false;
  for (;;) {
    Status s = Status::kOk;
    if (!replay || !g_input_done) {
      s = t.input->handle(kHandleTimeoutMs);
      if (s == Status::kEndOfStream ||
          (replay && s != Status::kOk && s != Status::kCapacityExceeded && s != Status::kTimeout)) {
        if (s != Status::kEndOfStream) {
          std::fprintf(stderr, "areomap-rover: %s: log replay stopped: %s\n", options.lcm_url,
                       areomap::statusName(s));
          input_failed = s == Status::kIoError;
        }
        std::lock_guard<std::mutex> lock(g_mutex);
        g_input_done = true;
        g_wake.notify_all();
      }
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(kHandleTimeoutMs));
    }
    drainOutbox(t.output, clock);
    if (g_last_status_bytes > 0 &&
        clock.monotonicUtime() - g_last_status_us >= static_cast<int64_t>(options.heartbeat_s * 1e6)) {
      publishStatus(t.output, clock);
    }
    if (options.max_seconds > 0.0 &&
        clock.monotonicUtime() - start_us > static_cast<int64_t>(options.max_seconds * 1e6))
      g_stop.store(true);
    const bool finished = g_finished.load() && options.exit_at_end;
    if (g_stop.load() || finished) {
      std::lock_guard<std::mutex> lock(g_mutex);
      g_input_done = true;
      g_wake.notify_all();
    }
    bool join = g_stop.load();
    {
      std::lock_guard<std::mutex> lock(g_mutex);
      join = join || (g_input_done && g_inbox.records() == 0 && (finished || replay));
    }
    if (!join) continue;
    if (!awaitPipeline(t.output, clock)) {
      writeStderr(
          "areomap-rover: stopped while the pipeline was busy with a pair for longer than the grace "
          "time; exiting without it\n");
      std::fflush(nullptr);
      std::_Exit(1);
    }
    pipeline.join();
    drainOutbox(t.output, clock);  // last publications
    break;
  }
  return input_failed;
}

// The run's figures at exit (stderr).
void printSummary() {
  const areomap::RoverCounters& c = g_node.counters();
  std::fprintf(
      stderr,
      "areomap-rover: pairs seen %d, accepted %d, rejected %d; gaps %d, duplicates %d, reordered %d; "
      "last adjustment %d sweeps, rms %.3f px; panorama %.2f s; heap allocations after start-up: "
      "pipeline thread %lld (reported as heap_allocs_after_init), whole process %lld%s; memory %lld "
      "bytes (static and start-up reserve)\n",
      c.pairs_seen, c.pairs_accepted, c.pairs_rejected, c.sequence_gaps, c.duplicates, c.reordered,
      c.last_sweeps, c.last_rms_px, c.panorama_seconds, static_cast<long long>(g_node.heapPipeline()),
      static_cast<long long>(g_node.heapProcess()), areomap::heapCounterActive() ? "" : " (counter inactive)",
      static_cast<long long>(g_node.memoryBytes()));
  const double pairs = c.pairs_accepted > 0 ? static_cast<double>(c.pairs_accepted) : 1.0;
  std::fprintf(
      stderr,
      "areomap-rover: seconds per accepted pair: decode %.3f, ties + coarse DEM %.3f, network + adjustment "
      "%.3f, publish %.3f; inbox refused %llu, waited for room %llu, peak %zu of %zu bytes\n",
      c.stage_seconds[static_cast<int>(areomap::RoverStage::kDecode)] / pairs,
      c.stage_seconds[static_cast<int>(areomap::RoverStage::kMatch)] / pairs,
      c.stage_seconds[static_cast<int>(areomap::RoverStage::kAdjust)] / pairs,
      c.stage_seconds[static_cast<int>(areomap::RoverStage::kPublish)] / pairs,
      static_cast<unsigned long long>(g_inbox_refused), static_cast<unsigned long long>(g_inbox_waits),
      g_inbox_peak_bytes, kInboxBytes);
  const areomap::RoverTraverse& traverse = g_node.traverse();
  if (traverse.siteCount() == 0) return;
  // The on-board localisation: how each site was placed, and what the site-pose steps cost.
  int32_t tied = 0, registered = 0, refused = 0;
  for (int32_t k = 0; k < traverse.siteCount(); ++k) {
    const areomap::RoverSiteRecord& site = traverse.site(k);
    tied += site.status == areomap::site_pose_t::STATUS_TIED ? 1 : 0;
    registered += site.registration == areomap::site_pose_t::REGISTRATION_OK ? 1 : 0;
    refused += site.registration == areomap::site_pose_t::REGISTRATION_REFUSED ? 1 : 0;
  }
  std::fprintf(stderr,
               "areomap-rover: traverse: %d sites, %d tied by cross-site ties, legs registered %d, refused %d; "
               "site-pose steps %.3f s in all, %.3f s per site after the first\n",
               static_cast<int>(traverse.siteCount()), static_cast<int>(tied), static_cast<int>(registered),
               static_cast<int>(refused), c.traverse_seconds,
               traverse.siteCount() > 1 ? c.traverse_seconds / (traverse.siteCount() - 1) : 0.0);
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  const int parsed = parseOptions(argc, argv, options);
  if (parsed >= 0) return parsed;
  const areomap::platform::UrlScheme scheme = areomap::platform::urlScheme(options.lcm_url);
  if (scheme == areomap::platform::UrlScheme::kInvalid) return usageError("--lcm: unknown URL scheme");
  const bool replay = scheme == areomap::platform::UrlScheme::kFile;
  if (replay) options.exit_at_end = true;

  std::signal(SIGALRM, onStopWatchdog);
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  areomap::platform::PosixClock clock;
  areomap::platform::ArenaJpegDecoder jpeg(g_jpeg_arena, sizeof(g_jpeg_arena));
  if (!areomap::ok(jpeg.open())) {
    std::fprintf(stderr, "areomap-rover: the JPEG decoder did not start: %s\n", jpeg.lastError());
    return 1;
  }
  Transports transports;
  if (!openTransports(options, replay, transports)) return 1;
  OutboxTransport outbox;
  areomap::RoverOptions rover_options;
  rover_options.log_to_stderr = !options.quiet;
  g_node.start(outbox, jpeg, clock, rover_options);
  g_node.setExtraStaticBytes(static_cast<int64_t>(sizeof(g_inbox_storage) + sizeof(g_outbox_storage) +
                                                  sizeof(g_replay_buffer) + sizeof(g_jpeg_arena)));
  std::fprintf(
      stderr,
      "areomap-rover: listening on %s (memory: static %lld + message buffers reserved at start-up %lld "
      "= %lld bytes, %.1f %% of the %llu-byte budget)\n",
      options.lcm_url, static_cast<long long>(g_node.staticBytes()),
      static_cast<long long>(g_node.reservedBytes()), static_cast<long long>(g_node.memoryBytes()),
      100.0 * static_cast<double>(g_node.memoryBytes()) /
          static_cast<double>(areomap::kStaticMemoryBudgetBytes),
      static_cast<unsigned long long>(areomap::kStaticMemoryBudgetBytes));

  std::thread pipeline(pipelineLoop, std::cref(options), std::cref(clock), std::ref(jpeg));
  const bool input_failed = transportLoop(options, replay, transports, clock, pipeline);
  printSummary();
  return input_failed ? 1 : 0;
}
