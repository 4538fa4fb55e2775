// Clock on clock_gettime (CLOCK_MONOTONIC and CLOCK_REALTIME).
#pragma once

#include "platform/Clock.hpp"

namespace areomap::platform {

class PosixClock final : public Clock {
 public:
  int64_t monotonicUtime() const override;
  int64_t wallUtime() const override;
};

}  // namespace areomap::platform
