#include "platform/posix/LcmTransport.hpp"

#include <lcm/lcm.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>

namespace areomap::platform {
namespace {

bool plainChannel(const char* channel) {
  if (channel == nullptr || channel[0] == '\0') return false;
  std::size_t n = 0;
  for (const char* c = channel; *c != '\0'; ++c, ++n) {
    const bool allowed = (*c >= 'A' && *c <= 'Z') || (*c >= 'a' && *c <= 'z') || (*c >= '0' && *c <= '9') ||
                         *c == '_' || *c == '-' || *c == '/';
    if (!allowed || n + 1 >= LcmTransport::kMaxChannelChars) return false;
  }
  return true;
}

}  // namespace

int64_t probeReceiveBufferBytes(int64_t requested) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return -1;
  int value = requested > 0x7fffffff ? 0x7fffffff : static_cast<int>(requested);
  int granted = -1;
  socklen_t len = sizeof(granted);
  if (::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &value, sizeof(value)) != 0 ||
      ::getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &granted, &len) != 0) {
    granted = -1;
  }
  ::close(fd);
  return granted;
}

int64_t kernelRmemMax() {
  std::FILE* f = std::fopen("/proc/sys/net/core/rmem_max", "r");
  if (f == nullptr) return -1;
  long long value = -1;
  if (std::fscanf(f, "%lld", &value) != 1) value = -1;
  std::fclose(f);
  return value;
}

LcmTransport::~LcmTransport() {
  close();
}

void LcmTransport::close() {
  if (lcm_ != nullptr) lcm_destroy(static_cast<lcm_t*>(lcm_));
  lcm_ = nullptr;
  num_subscriptions_ = 0;
  end_of_log_ = false;
}

Status LcmTransport::open(const char* url) {
  close();
  const Status completed = completeUrl(url, url_, sizeof(url_));
  if (!ok(completed)) return completed;
  scheme_ = urlScheme(url_);
  reading_log_ = false;
  requested_recv_buf_ = 0;
  effective_recv_buf_ = 0;
  if (scheme_ == UrlScheme::kFile) {
    const char* mode = std::strstr(url_, "mode=");
    reading_log_ = mode == nullptr || mode[5] == 'r';
  }
  if (scheme_ == UrlScheme::kUdpm) {
    (void)urlOption(url_, "recv_buf_size", requested_recv_buf_);
    effective_recv_buf_ = probeReceiveBufferBytes(requested_recv_buf_);
    if (effective_recv_buf_ < requested_recv_buf_) {
      std::fprintf(stderr,
                   "LcmTransport: the kernel grants %lld receive-buffer bytes, %lld were asked for "
                   "(net.core.rmem_max = %lld); large messages may be dropped. Raise it with: "
                   "sysctl -w net.core.rmem_max=%lld\n",
                   static_cast<long long>(effective_recv_buf_), static_cast<long long>(requested_recv_buf_),
                   static_cast<long long>(kernelRmemMax()), static_cast<long long>(requested_recv_buf_));
    }
  }
  lcm_ = lcm_create(url_);
  return lcm_ != nullptr ? Status::kOk : Status::kIoError;
}

Status LcmTransport::publish(const char* channel, const uint8_t* data, std::size_t size) {
  if (!plainChannel(channel) || (data == nullptr && size > 0)) return Status::kInvalidArgument;
  if (lcm_ == nullptr || reading_log_) return Status::kIoError;
  if (size > 0x7fffffffu) return Status::kCapacityExceeded;
  return lcm_publish(static_cast<lcm_t*>(lcm_), channel, data, static_cast<unsigned int>(size)) == 0
             ? Status::kOk
             : Status::kIoError;
}

void LcmTransport::onMessage(const void* rbuf, const char* channel, void* user) {
  const auto* buffer = static_cast<const lcm_recv_buf_t*>(rbuf);
  const auto* subscription = static_cast<const Subscription*>(user);
  subscription->handler(subscription->context, channel, static_cast<const uint8_t*>(buffer->data),
                        buffer->data_size);
}

Status LcmTransport::subscribe(const char* channel, MessageHandler handler, void* context) {
  if (!plainChannel(channel) || handler == nullptr) return Status::kInvalidArgument;
  if (lcm_ == nullptr) return Status::kIoError;
  if (num_subscriptions_ >= kMaxSubscriptions) return Status::kCapacityExceeded;
  Subscription& s = subscriptions_[num_subscriptions_];
  std::snprintf(s.channel, sizeof(s.channel), "%s", channel);
  s.handler = handler;
  s.context = context;
  const auto trampoline = [](const lcm_recv_buf_t* rbuf, const char* ch, void* user) {
    onMessage(rbuf, ch, user);
  };
  s.lcm_subscription = lcm_subscribe(static_cast<lcm_t*>(lcm_), s.channel, trampoline, &s);
  if (s.lcm_subscription == nullptr) return Status::kIoError;
  if (queue_capacity_ >= 0) {
    lcm_subscription_set_queue_capacity(static_cast<lcm_subscription_t*>(s.lcm_subscription), queue_capacity_);
  }
  ++num_subscriptions_;
  return Status::kOk;
}

Status LcmTransport::handle(int32_t timeout_ms) {
  if (lcm_ == nullptr) return Status::kIoError;
  if (end_of_log_) return Status::kEndOfStream;
  const int result = lcm_handle_timeout(static_cast<lcm_t*>(lcm_), timeout_ms < 0 ? 0 : timeout_ms);
  if (result > 0) return Status::kOk;
  if (result == 0) return Status::kTimeout;
  if (reading_log_) {
    end_of_log_ = true;
    return Status::kEndOfStream;
  }
  return Status::kIoError;
}

}  // namespace areomap::platform
