// A heap-free replay of an LCM log file (the format lcm-logger and file://?mode=w write) as a Transport.
// LCM's own file:// provider allocates every event it reads on the caller's thread (measured in
// tests/platform/TransportTest.cpp); this reader uses read() into one caller-provided buffer, so the rover
// pipeline can replay a panorama with zero heap after open(). Events are delivered as fast as handle() is
// called (no real-time pacing); the event's log timestamp is lastEventUtime().
#pragma once

#include "platform/Transport.hpp"

namespace areomap::platform {

class LcmLogReplay final : public Transport {
 public:
  static constexpr int32_t kMaxSubscriptions = 16;  // channels one node listens to (7 exist)
  static constexpr std::size_t kMaxChannelChars =
      256;  // LCM's own channel-name limit is 63; logs may hold longer

  // `buffer` holds one event's payload: size it for the largest message (a stereo pair).
  LcmLogReplay(uint8_t* buffer, std::size_t capacity_bytes) : buffer_(buffer), capacity_(capacity_bytes) {}
  ~LcmLogReplay() override;
  LcmLogReplay(const LcmLogReplay&) = delete;
  LcmLogReplay& operator=(const LcmLogReplay&) = delete;

  // Opens the log file (a path, or a file:// URL whose query is ignored). kIoError when it cannot be read.
  [[nodiscard]] Status open(const char* path_or_url);
  void close();

  // A replay is read-only: kIoError.
  [[nodiscard]] Status publish(const char* channel, const uint8_t* data, std::size_t size) override;
  [[nodiscard]] Status subscribe(const char* channel, MessageHandler handler, void* context) override;
  // Reads the next event and hands it to the subscribers of its channel. kOk (read, delivered or not),
  // kEndOfStream at the end of the log, kTruncated when the log ends inside an event, kCorruptData for a
  // bad sync word or length, kCapacityExceeded for an event larger than the buffer (skipped, counted; the
  // next call goes on with the following event), kIoError for a read error. timeout_ms >= 0: kTimeout when
  // no byte of the next event can be read within it (a pipe or FIFO; a regular file never times out);
  // < 0 waits. Once an event has begun, its remaining bytes are waited for.
  [[nodiscard]] Status handle(int32_t timeout_ms) override;

  int64_t lastEventUtime() const { return last_utime_; }
  uint64_t eventsRead() const { return events_; }
  uint64_t eventsTooLarge() const { return too_large_; }

 private:
  struct Subscription {
    char channel[kMaxChannelChars];
    MessageHandler handler;
    void* context;
  };
  Status readExactly(uint8_t* out, std::size_t bytes, bool at_event_start);

  uint8_t* buffer_;
  std::size_t capacity_;
  int fd_ = -1;
  bool failed_ = false;
  int64_t last_utime_ = 0;
  uint64_t events_ = 0;
  uint64_t too_large_ = 0;
  char channel_[kMaxChannelChars] = {0};
  int32_t num_subscriptions_ = 0;
  Subscription subscriptions_[kMaxSubscriptions] = {};
};

}  // namespace areomap::platform
