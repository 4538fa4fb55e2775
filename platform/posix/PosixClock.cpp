#include "platform/posix/PosixClock.hpp"

#include <ctime>

namespace areomap::platform {
namespace {

int64_t utimeOf(clockid_t id) {
  timespec ts{};
  clock_gettime(id, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000 + ts.tv_nsec / 1000;
}

}  // namespace

int64_t PosixClock::monotonicUtime() const {
  return utimeOf(CLOCK_MONOTONIC);
}
int64_t PosixClock::wallUtime() const {
  return utimeOf(CLOCK_REALTIME);
}

}  // namespace areomap::platform
