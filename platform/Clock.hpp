// Time for the nodes: monotonic time for durations and timeouts, wall time for message utime fields.
#pragma once

#include <cstdint>

namespace areomap::platform {

class Clock {
 public:
  virtual ~Clock() = default;
  // Microseconds on a clock that never jumps (CLOCK_MONOTONIC); for durations only.
  virtual int64_t monotonicUtime() const = 0;
  // Microseconds since the Unix epoch (CLOCK_REALTIME); for the utime field of messages.
  virtual int64_t wallUtime() const = 0;
};

}  // namespace areomap::platform
