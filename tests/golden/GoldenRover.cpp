// golden_rover LOG.lcm OUT.csv: the rover pipeline (RoverNode, as areomap-rover runs it) over a camera-stream
// log read with the heap-free replay (platform::LcmLogReplay, no LCM runtime needed, so it runs on every
// target), single-threaded; every tie-point observation it publishes and its final EO go into OUT.csv with
// doubles as C99 hexadecimal floats (%a: every bit, read back exactly by tests/golden/compare_golden.py).
// Per-stage seconds go to stderr (they differ between runs and targets; not part of the golden output).
// The heap allocations the pipeline made after start() (its own, without this tool's writing of the CSV) go
// into OUT.csv too (`heap,ACTIVE,COUNT`): compare_golden.py requires 0 on the target, so the golden test also
// proves the matcher and the adjuster heap-free there (the reason CI may leave PanoramaMatcher out on
// powerpc: toolchains/README.md "CI").
//
// Used by tests/golden/run_golden.sh (CTest label `golden`): the same log natively and on each target under
// qemu, outputs compared. Exit: 0 ok, 2 usage, 1 error (unreadable log, no final EO, output not written).
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <cstring>

#include "areomap/eo_solution_t.hpp"
#include "areomap/tiepoints_t.hpp"
#include "firmware_core/node/RoverNode.hpp"
#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "platform/posix/ArenaJpegDecoder.hpp"
#include "platform/posix/LcmLogReplay.hpp"
#include "platform/posix/PosixClock.hpp"

namespace {

using areomap::Status;

areomap::RoverNode g_node;  // ~41 MiB: static, as in areomap-rover
uint8_t g_replay_buffer[2u * areomap::kMaxJpegBytes + 64u * 1024u];
uint8_t g_jpeg_arena[areomap::platform::ArenaJpegDecoder::kArenaBytes];
uint64_t g_harness_allocations = 0;   // made while this tool decodes and writes a publication
uint64_t g_pipeline_allocations = 0;  // made by the pipeline after start(), without the above

// Receives the pipeline's publications: tie points and the final EO are written to the CSV at once.
class CsvTransport final : public areomap::platform::Transport {
 public:
  explicit CsvTransport(std::FILE* out) : out_(out) {}
  Status publish(const char* channel, const uint8_t* data, std::size_t size) override {
    const areomap::HeapAllocationScope scope;
    Status s = Status::kOk;  // status and coarse DEM: not compared
    if (std::strcmp(channel, areomap::channels::kTiePoints) == 0) s = writeTies(data, size);
    if (std::strcmp(channel, areomap::channels::kEoSolution) == 0) s = writeEo(data, size);
    g_harness_allocations += scope.allocations();
    return s;
  }
  Status subscribe(const char*, areomap::platform::MessageHandler, void*) override {
    return Status::kUnsupported;
  }
  Status handle(int32_t) override { return Status::kTimeout; }
  int finalSolutions() const { return finals_; }
  Status firstError() const { return error_; }

 private:
  Status fail(Status s) {
    if (areomap::ok(error_)) error_ = s;
    return s;
  }
  Status writeTies(const uint8_t* data, std::size_t size) {
    const Status s = areomap::msgs::decodeMessage(data, size, ties_);
    if (!areomap::ok(s)) return fail(s);
    for (int32_t i = 0; i < ties_.num_observations; ++i) {
      const int idx = ties_.image_index[static_cast<std::size_t>(i)];
      const char* stem =
          idx >= 0 && idx < ties_.num_images ? ties_.image_stems[static_cast<std::size_t>(idx)].c_str() : "?";
      std::fprintf(out_, "tie,%d,%d,%s,%d,%a,%a\n", ties_.pair_id,
                   ties_.point_id[static_cast<std::size_t>(i)], stem,
                   static_cast<int>(ties_.kind[static_cast<std::size_t>(i)]),
                   ties_.sample_px[static_cast<std::size_t>(i)], ties_.line_px[static_cast<std::size_t>(i)]);
    }
    return Status::kOk;
  }
  Status writeEo(const uint8_t* data, std::size_t size) {
    const Status s = areomap::msgs::decodeMessage(data, size, eo_);
    if (!areomap::ok(s)) return fail(s);
    if (!eo_.is_final) return Status::kOk;
    finals_ += 1;
    std::fprintf(out_, "final,%d,%d,%d,%a,%a\n", eo_.sweeps, eo_.iterations, static_cast<int>(eo_.stop_rule),
                 eo_.rms_px, eo_.sigma0);
    for (const areomap::eo_entry_t& e : eo_.images) {
      std::fprintf(out_, "eo,%s,%d,%d,%a,%a,%a,%a,%a,%a,%a,%a,%a,%a,%a,%a\n", e.stem.c_str(), e.pair_id,
                   static_cast<int>(e.side), e.center_m[0], e.center_m[1], e.center_m[2], e.omega_rad,
                   e.phi_rad, e.kappa_rad, e.sigma_center_m[0], e.sigma_center_m[1], e.sigma_center_m[2],
                   e.sigma_angles_rad[0], e.sigma_angles_rad[1], e.sigma_angles_rad[2]);
    }
    return Status::kOk;
  }

  std::FILE* out_;
  areomap::tiepoints_t ties_;
  areomap::eo_solution_t eo_;
  int finals_ = 0;
  Status error_ = Status::kOk;
};

void onStereoPair(void*, const char*, const uint8_t* data, std::size_t size) {
  const areomap::HeapAllocationScope scope;
  const uint64_t harness = g_harness_allocations;
  g_node.handleStereoPair(data, size);
  g_pipeline_allocations += scope.allocations() - (g_harness_allocations - harness);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 2 && (std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0)) {
    std::puts(
        "usage: golden_rover LOG.lcm OUT.csv  (the rover pipeline over a log; tie points and final EO as hex "
        "floats)");
    return 0;
  }
  if (argc != 3) {
    std::fputs("usage: golden_rover LOG.lcm OUT.csv (see --help)\n", stderr);
    return 2;
  }
  areomap::platform::ArenaJpegDecoder jpeg(g_jpeg_arena, sizeof(g_jpeg_arena));
  if (!areomap::ok(jpeg.open())) {
    std::fprintf(stderr, "golden_rover: the JPEG decoder did not start: %s\n", jpeg.lastError());
    return 1;
  }
  areomap::platform::LcmLogReplay log(g_replay_buffer, sizeof(g_replay_buffer));
  if (!areomap::ok(log.open(argv[1]))) {
    std::fprintf(stderr, "golden_rover: %s: cannot read the log\n", argv[1]);
    return 1;
  }
  std::FILE* out = std::fopen(argv[2], "w");
  if (out == nullptr) {
    std::fprintf(stderr, "golden_rover: %s: cannot write\n", argv[2]);
    return 1;
  }
  std::fputs("# golden_rover: kind,fields...; doubles as %a\n", out);
  areomap::platform::PosixClock clock;
  CsvTransport csv(out);
  areomap::RoverOptions options;
  options.log_to_stderr = false;
  g_node.start(csv, jpeg, clock, options);
  if (!areomap::ok(log.subscribe(areomap::channels::kStereoPair, onStereoPair, nullptr))) return 1;
  const auto t0 = std::chrono::steady_clock::now();
  Status s = Status::kOk;
  while ((s = log.handle(0)) == Status::kOk || s == Status::kCapacityExceeded) {
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::fprintf(out, "heap,%d,%" PRIu64 "\n", areomap::heapCounterActive() ? 1 : 0, g_pipeline_allocations);
  const bool written = std::fclose(out) == 0;
  const areomap::RoverCounters& c = g_node.counters();
  const double* st = c.stage_seconds;
  using areomap::RoverStage;
  std::fprintf(
      stderr,
      "golden_rover: pairs accepted %d of %d; final solutions %d; stage seconds: decode %.4f, ties + coarse "
      "DEM %.4f, network + adjustment %.4f, publish %.4f; wall %.3f s; heap allocations after start %" PRIu64
      "%s\n",
      c.pairs_accepted, c.pairs_seen, csv.finalSolutions(), st[static_cast<int>(RoverStage::kDecode)],
      st[static_cast<int>(RoverStage::kMatch)], st[static_cast<int>(RoverStage::kAdjust)],
      st[static_cast<int>(RoverStage::kPublish)], wall, g_pipeline_allocations,
      areomap::heapCounterActive() ? "" : " (not counted: no heap counter)");
  if (s != Status::kEndOfStream) {
    std::fprintf(stderr, "golden_rover: %s: replay stopped: %s\n", argv[1], areomap::statusName(s));
    return 1;
  }
  if (!areomap::ok(csv.firstError())) {
    std::fprintf(stderr, "golden_rover: a published message did not decode: %s\n",
                 areomap::statusName(csv.firstError()));
    return 1;
  }
  if (csv.finalSolutions() != 1 || !written) {
    std::fprintf(stderr, "golden_rover: %d final EO solutions (expected 1)%s\n", csv.finalSolutions(),
                 written ? "" : "; the output was not fully written");
    return 1;
  }
  return 0;
}
