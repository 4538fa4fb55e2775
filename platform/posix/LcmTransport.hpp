// Transport on LCM (udpm://, file://, memq://; URLs completed by completeUrl(), see TransportUrl.hpp).
// open() allocates (LCM context, receive thread); so does subscribe(): call both at start-up.
#pragma once

#include "platform/Transport.hpp"
#include "platform/TransportUrl.hpp"

namespace areomap::platform {

class LcmTransport final : public Transport {
 public:
  static constexpr int32_t kMaxSubscriptions = 16;  // channels one node listens to (7 exist)
  static constexpr std::size_t kMaxChannelChars = 64;

  LcmTransport() = default;
  ~LcmTransport() override;
  LcmTransport(const LcmTransport&) = delete;
  LcmTransport& operator=(const LcmTransport&) = delete;

  // Opens the provider of `url` (null or "" = the default udpm URL). kInvalidArgument for an unknown scheme,
  // kIoError when LCM cannot create it (no multicast route, unreadable log file...).
  [[nodiscard]] Status open(const char* url);
  void close();

  [[nodiscard]] Status publish(const char* channel, const uint8_t* data, std::size_t size) override;
  // `channel` is a plain name: letters, digits, '_', '-', '/' (LCM would read other characters as a regex).
  [[nodiscard]] Status subscribe(const char* channel, MessageHandler handler, void* context) override;
  [[nodiscard]] Status handle(int32_t timeout_ms) override;
  // How many received messages LCM keeps per subscription while handle() is not called, for the
  // subscriptions made after this call: 0 = no limit; beyond it LCM drops the newest. LCM's default (30)
  // suits a node that handles all the time (the rover's transport thread); a node that stops reading for
  // minutes (the ground making products) would lose the stream and the rover's messages of that time.
  void setQueueCapacity(int32_t messages) { queue_capacity_ = messages; }

  const char* url() const { return url_; }  // the completed URL in use
  // udpm only (0 otherwise): the receive buffer asked for in the URL, and what the kernel grants a socket
  // that asks for it (Linux reports twice the request, capped at twice net.core.rmem_max).
  int64_t requestedReceiveBufferBytes() const { return requested_recv_buf_; }
  int64_t receiveBufferBytes() const { return effective_recv_buf_; }

 private:
  struct Subscription {
    char channel[kMaxChannelChars];
    MessageHandler handler;
    void* context;
    void* lcm_subscription;
  };
  static void onMessage(const void* rbuf, const char* channel, void* user);

  void* lcm_ = nullptr;
  UrlScheme scheme_ = UrlScheme::kInvalid;
  bool reading_log_ = false;
  bool end_of_log_ = false;
  char url_[kMaxUrlChars] = {0};
  int64_t requested_recv_buf_ = 0;
  int64_t effective_recv_buf_ = 0;
  int32_t num_subscriptions_ = 0;
  int32_t queue_capacity_ = -1;  // -1: LCM's default
  Subscription subscriptions_[kMaxSubscriptions] = {};
};

// What the kernel grants a UDP socket that asks for `requested` receive-buffer bytes (getsockopt after
// setsockopt SO_RCVBUF), and net.core.rmem_max (-1 when unreadable).
int64_t probeReceiveBufferBytes(int64_t requested);
int64_t kernelRmemMax();

}  // namespace areomap::platform
