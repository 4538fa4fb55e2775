// An in-process Transport for tests: published messages queue in a caller-provided byte buffer (no heap)
// and handle() delivers the oldest to the subscribers of its channel, in order. A message that does not
// fit the free space is refused with kCapacityExceeded and counted in refused().
#pragma once

#include "platform/Transport.hpp"

namespace areomap::platform {

class MemoryTransport final : public Transport {
 public:
  static constexpr int32_t kMaxChannels = 16;
  static constexpr int32_t kMaxSubscriptions = 16;
  static constexpr std::size_t kMaxChannelChars = 64;

  MemoryTransport(uint8_t* storage, std::size_t capacity_bytes)
      : storage_(storage), capacity_(capacity_bytes) {}

  [[nodiscard]] Status publish(const char* channel, const uint8_t* data, std::size_t size) override;
  [[nodiscard]] Status subscribe(const char* channel, MessageHandler handler, void* context) override;
  // kOk after delivering one message, kTimeout when the queue is empty (it never waits).
  [[nodiscard]] Status handle(int32_t timeout_ms) override;

  std::size_t queuedMessages() const { return queued_; }
  uint64_t refused() const { return refused_; }

 private:
  int32_t channelIndex(const char* channel, bool add);

  struct Subscription {
    int32_t channel;
    MessageHandler handler;
    void* context;
  };
  uint8_t* storage_;
  std::size_t capacity_;
  std::size_t head_ = 0;  // oldest record
  std::size_t tail_ = 0;  // end of the newest
  std::size_t queued_ = 0;
  uint64_t refused_ = 0;
  int32_t num_channels_ = 0;
  char channels_[kMaxChannels][kMaxChannelChars] = {};
  int32_t num_subscriptions_ = 0;
  Subscription subscriptions_[kMaxSubscriptions] = {};
};

}  // namespace areomap::platform
