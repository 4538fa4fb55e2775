// Publish/subscribe of raw message bytes by channel (LCM on POSIX, in memory for tests). Decoding with the
// generated types happens in the nodes (msgs/MessageCheck.hpp: decodeMessage); this layer moves bytes only.
//
// Receive path without heap in the pipeline: handle() calls the subscriber's handler on the caller's
// thread with a pointer to the received bytes, valid during the call only; the handler copies them into a
// buffer the pipeline allocated at start-up (MessageSlot below does exactly that). The LCM library itself
// allocates on its own receive thread (its ring buffer and fragment reassembly); that is outside the
// pipeline and is accepted.
#pragma once

#include <cstddef>
#include <cstdint>

#include "firmware_core/base/Status.hpp"

namespace areomap::platform {

// Called for each message on a subscribed channel: `data`/`size` are valid during the call only.
using MessageHandler = void (*)(void* context, const char* channel, const uint8_t* data, std::size_t size);

class Transport {
 public:
  virtual ~Transport() = default;

  // Sends `size` bytes on `channel`. kInvalidArgument for a null or empty channel, kIoError when the
  // transport refuses (closed, read-only log, network error).
  [[nodiscard]] virtual Status publish(const char* channel, const uint8_t* data, std::size_t size) = 0;

  // Calls handler(context, ...) for every message on exactly `channel` (not a pattern). kCapacityExceeded
  // beyond the transport's subscription table.
  [[nodiscard]] virtual Status subscribe(const char* channel, MessageHandler handler, void* context) = 0;

  // Waits up to timeout_ms (0 = poll) for one message and dispatches it. kOk when one was dispatched,
  // kTimeout when none arrived in time, kEndOfStream when a log replay has no more messages, kIoError when
  // the transport failed.
  [[nodiscard]] virtual Status handle(int32_t timeout_ms) = 0;
};

// A fixed buffer that receives one message: pass &slot as the context and MessageSlot::store as the handler.
// A message larger than the capacity is not copied: `status` says kCapacityExceeded and `dropped` counts it.
struct MessageSlot {
  uint8_t* storage = nullptr;  // caller's buffer, allocated at start-up
  std::size_t capacity = 0;
  std::size_t size = 0;              // bytes of the last message stored
  uint64_t received = 0;             // messages handed to store()
  uint64_t dropped = 0;              // of which too large for the buffer
  Status status = Status::kTimeout;  // of the last store(): kOk, kCapacityExceeded

  static void store(void* context, const char* channel, const uint8_t* data, std::size_t size);
};

}  // namespace areomap::platform
