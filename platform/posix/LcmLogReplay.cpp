#include "platform/posix/LcmLogReplay.hpp"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace areomap::platform {
namespace {

constexpr uint32_t kLcmSyncWord = 0xEDA1DA01u;  // starts every event of an LCM log (eventlog.c)
constexpr int32_t kEventHeaderBytes =
    4 + 8 + 8 + 4 + 4;                      // sync, event number, utime, channel and data lengths
constexpr int32_t kMaxReadCalls = 1 << 20;  // bounds one readExactly loop (a read returns >= 1 byte)

uint64_t bigEndian(const uint8_t* p, int32_t bytes) {
  uint64_t v = 0;
  for (int32_t i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}

}  // namespace

LcmLogReplay::~LcmLogReplay() {
  close();
}

void LcmLogReplay::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  failed_ = false;
  num_subscriptions_ = 0;
}

Status LcmLogReplay::open(const char* path_or_url) {
  close();
  if (path_or_url == nullptr) return Status::kInvalidArgument;
  const char* path = std::strncmp(path_or_url, "file://", 7) == 0 ? path_or_url + 7 : path_or_url;
  char plain[1024];
  const int n = std::snprintf(plain, sizeof(plain), "%s", path);
  if (n < 0 || static_cast<std::size_t>(n) >= sizeof(plain)) return Status::kCapacityExceeded;
  char* query = std::strchr(plain, '?');
  if (query != nullptr) *query = '\0';
  fd_ = ::open(plain, O_RDONLY | O_CLOEXEC);
  events_ = 0;
  too_large_ = 0;
  return fd_ >= 0 ? Status::kOk : Status::kIoError;
}

Status LcmLogReplay::publish(const char* /*channel*/, const uint8_t* /*data*/, std::size_t /*size*/) {
  return Status::kIoError;
}

Status LcmLogReplay::subscribe(const char* channel, MessageHandler handler, void* context) {
  if (channel == nullptr || channel[0] == '\0' || handler == nullptr) return Status::kInvalidArgument;
  if (std::strlen(channel) >= kMaxChannelChars || num_subscriptions_ >= kMaxSubscriptions) {
    return Status::kCapacityExceeded;
  }
  Subscription& s = subscriptions_[num_subscriptions_++];
  std::snprintf(s.channel, sizeof(s.channel), "%s", channel);
  s.handler = handler;
  s.context = context;
  return Status::kOk;
}

Status LcmLogReplay::readExactly(uint8_t* out, std::size_t bytes, bool at_event_start) {
  std::size_t done = 0;
  for (int32_t call = 0; call < kMaxReadCalls && done < bytes; ++call) {
    const ssize_t n = ::read(fd_, out + done, bytes - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return Status::kIoError;
    if (n == 0) return at_event_start && done == 0 ? Status::kEndOfStream : Status::kTruncated;
    done += static_cast<std::size_t>(n);
  }
  return done == bytes ? Status::kOk : Status::kIoError;
}

Status LcmLogReplay::handle(int32_t timeout_ms) {
  if (fd_ < 0) return Status::kIoError;
  if (failed_) return Status::kCorruptData;  // lost sync: nothing after it can be trusted
  if (timeout_ms >= 0) {
    // A regular file is always readable; a pipe or FIFO with a writer that has nothing to say would block
    // the caller (and its stop request) until it writes: wait at most timeout_ms for the next event.
    pollfd p{fd_, POLLIN, 0};
    const int ready = ::poll(&p, 1, timeout_ms);
    if (ready == 0 || (ready < 0 && errno == EINTR)) return Status::kTimeout;
    if (ready < 0) return Status::kIoError;
  }
  uint8_t header[kEventHeaderBytes];
  Status status = readExactly(header, sizeof(header), true);
  if (!ok(status)) return status;
  if (bigEndian(header, 4) != kLcmSyncWord) {
    failed_ = true;
    return Status::kCorruptData;
  }
  last_utime_ = static_cast<int64_t>(bigEndian(header + 12, 8));
  const auto channel_bytes = static_cast<int32_t>(bigEndian(header + 20, 4));
  const auto data_bytes = static_cast<int32_t>(bigEndian(header + 24, 4));
  if (channel_bytes <= 0 || data_bytes < 0) {
    failed_ = true;
    return Status::kCorruptData;
  }
  if (static_cast<std::size_t>(channel_bytes) >= kMaxChannelChars) {
    failed_ = true;  // not a log this reader can follow
    return Status::kCapacityExceeded;
  }
  status = readExactly(reinterpret_cast<uint8_t*>(channel_), static_cast<std::size_t>(channel_bytes), false);
  if (!ok(status)) return status;
  channel_[channel_bytes] = '\0';
  ++events_;
  if (static_cast<std::size_t>(data_bytes) > capacity_ || buffer_ == nullptr) {
    ++too_large_;
    if (::lseek(fd_, data_bytes, SEEK_CUR) < 0) return Status::kIoError;
    return Status::kCapacityExceeded;
  }
  status = readExactly(buffer_, static_cast<std::size_t>(data_bytes), false);
  if (!ok(status)) return status;
  for (int32_t i = 0; i < num_subscriptions_; ++i) {
    const Subscription& s = subscriptions_[i];
    if (std::strcmp(s.channel, channel_) == 0) {
      s.handler(s.context, channel_, buffer_, static_cast<std::size_t>(data_bytes));
    }
  }
  return Status::kOk;
}

}  // namespace areomap::platform
