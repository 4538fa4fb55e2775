// A Clock that tests set and advance by hand.
#pragma once

#include "platform/Clock.hpp"

namespace areomap::platform {

class ManualClock final : public Clock {
 public:
  explicit ManualClock(int64_t wall_utime = 0, int64_t monotonic_utime = 0)
      : wall_(wall_utime), monotonic_(monotonic_utime) {}
  int64_t monotonicUtime() const override { return monotonic_; }
  int64_t wallUtime() const override { return wall_; }
  void advance(int64_t micros) {
    wall_ += micros;
    monotonic_ += micros;
  }
  void setWallUtime(int64_t utime) { wall_ = utime; }

 private:
  int64_t wall_;
  int64_t monotonic_;
};

}  // namespace areomap::platform
