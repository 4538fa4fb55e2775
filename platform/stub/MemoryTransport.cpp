#include "platform/stub/MemoryTransport.hpp"

#include <cstring>

namespace areomap::platform {
namespace {

struct RecordHeader {
  int32_t channel;
  std::size_t size;
};

}  // namespace

int32_t MemoryTransport::channelIndex(const char* channel, bool add) {
  for (int32_t i = 0; i < num_channels_; ++i) {
    if (std::strcmp(channels_[i], channel) == 0) return i;
  }
  if (!add || num_channels_ >= kMaxChannels || std::strlen(channel) >= kMaxChannelChars) return -1;
  std::strcpy(channels_[num_channels_], channel);
  return num_channels_++;
}

Status MemoryTransport::publish(const char* channel, const uint8_t* data, std::size_t size) {
  if (channel == nullptr || channel[0] == '\0' || (data == nullptr && size > 0))
    return Status::kInvalidArgument;
  const int32_t index = channelIndex(channel, true);
  if (index < 0) return Status::kCapacityExceeded;
  if (queued_ == 0) head_ = tail_ = 0;
  if (storage_ == nullptr || sizeof(RecordHeader) + size > capacity_ - tail_) {
    ++refused_;
    return Status::kCapacityExceeded;
  }
  const RecordHeader header{index, size};
  std::memcpy(storage_ + tail_, &header, sizeof(header));
  if (size > 0) std::memcpy(storage_ + tail_ + sizeof(header), data, size);
  tail_ += sizeof(header) + size;
  ++queued_;
  return Status::kOk;
}

Status MemoryTransport::subscribe(const char* channel, MessageHandler handler, void* context) {
  if (channel == nullptr || channel[0] == '\0' || handler == nullptr) return Status::kInvalidArgument;
  const int32_t index = channelIndex(channel, true);
  if (index < 0 || num_subscriptions_ >= kMaxSubscriptions) return Status::kCapacityExceeded;
  subscriptions_[num_subscriptions_++] = Subscription{index, handler, context};
  return Status::kOk;
}

Status MemoryTransport::handle(int32_t /*timeout_ms*/) {
  if (queued_ == 0) return Status::kTimeout;
  RecordHeader header{};
  std::memcpy(&header, storage_ + head_, sizeof(header));
  const uint8_t* data = storage_ + head_ + sizeof(header);
  head_ += sizeof(header) + header.size;
  --queued_;
  for (int32_t i = 0; i < num_subscriptions_; ++i) {
    const Subscription& s = subscriptions_[i];
    if (s.channel == header.channel) s.handler(s.context, channels_[header.channel], data, header.size);
  }
  return Status::kOk;
}

}  // namespace areomap::platform
