// The rover node of the pack tests that feed it a stream directly (no transport in between): one node per
// test executable, started afresh by every run on a memory outbox, the static JPEG arena and the clock.
#pragma once

#include <cstdint>
#include <vector>

#include "firmware_core/node/RoverNode.hpp"
#include "ground/pack/Pack.hpp"
#include "msgs/Channels.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "platform/posix/ArenaJpegDecoder.hpp"
#include "platform/posix/PosixClock.hpp"
#include "platform/stub/MemoryTransport.hpp"

#include <CppUTest/TestHarness.h>

namespace areomap::test {

inline RoverNode& harnessRover() {
  static auto* n = new RoverNode();  // ~45 MiB, allocated once as on the rover
  return *n;
}
inline uint8_t g_harness_arena[platform::ArenaJpegDecoder::kArenaBytes];
inline uint8_t g_harness_outbox[4 * 1024 * 1024];

// Starts the node, lets `subscribe(outbox)` attach handlers to its publications, feeds every event
// (AREOMAP_STEREO_PAIR and AREOMAP_SITE messages) and forwards the publications after each. Returns the heap
// allocations of the pipeline (handleStereoPair, handleSite) alone.
template <class Subscribe>
uint64_t feedRover(const std::vector<LogEvent>& events, Subscribe subscribe) {
  platform::MemoryTransport outbox(g_harness_outbox, sizeof(g_harness_outbox));
  platform::ArenaJpegDecoder jpeg(g_harness_arena, sizeof(g_harness_arena));
  CHECK(ok(jpeg.open()));
  platform::PosixClock clock;
  RoverOptions options;
  options.log_to_stderr = false;
  harnessRover().start(outbox, jpeg, clock, options);
  subscribe(outbox);
  uint64_t allocations = 0;
  for (const LogEvent& e : events) {
    const uint64_t before = heapAllocationCountThisThread();
    if (e.channel == channels::kSite) {
      harnessRover().handleSite(e.data.data(), e.data.size());
    } else {
      harnessRover().handleStereoPair(e.data.data(), e.data.size());
    }
    allocations += heapAllocationCountThisThread() - before;
    for (int k = 0; k < 100 && outbox.handle(0) == Status::kOk; ++k) {
    }
  }
  return allocations;
}

}  // namespace areomap::test
