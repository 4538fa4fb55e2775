#include "ground/node/EventRecorder.hpp"

#include <chrono>
#include <cstring>

#include "ground/cli/Cli.hpp"

namespace areomap::ground {
namespace {

constexpr uint32_t kSyncWord = 0xEDA1DA01u;  // LCM event log: every event starts with it (big-endian)

void putBigEndian(uint8_t* out, uint64_t value, int bytes) {
  for (int i = bytes - 1; i >= 0; --i) {
    out[i] = static_cast<uint8_t>(value & 0xffu);
    value >>= 8;
  }
}

}  // namespace

EventRecorder::~EventRecorder() {
  if (file_ != nullptr) std::fclose(file_);
}

void EventRecorder::open(const std::string& path) {
  if (file_ != nullptr) std::fclose(file_);
  path_ = path;
  file_ = std::fopen(path.c_str(), "wb");
  if (file_ == nullptr) throw cli::InputError(path, "recording", "cannot create the log of received messages");
  events_ = 0;
}

void EventRecorder::record(const char* channel, const uint8_t* data, std::size_t size) {
  if (file_ == nullptr) return;
  const std::size_t channel_bytes = channel == nullptr ? 0 : std::strlen(channel);
  // Header: sync word, event number, timestamp (us), channel length, data length -- all big-endian.
  uint8_t header[4 + 8 + 8 + 4 + 4];
  const int64_t utime = std::chrono::duration_cast<std::chrono::microseconds>(
                            std::chrono::system_clock::now().time_since_epoch())
                            .count();
  putBigEndian(header, kSyncWord, 4);
  putBigEndian(header + 4, static_cast<uint64_t>(events_), 8);
  putBigEndian(header + 12, static_cast<uint64_t>(utime), 8);
  putBigEndian(header + 20, channel_bytes, 4);
  putBigEndian(header + 24, size, 4);
  const bool written = std::fwrite(header, 1, sizeof(header), file_) == sizeof(header) &&
                       std::fwrite(channel, 1, channel_bytes, file_) == channel_bytes &&
                       (size == 0 || std::fwrite(data, 1, size, file_) == size) && std::fflush(file_) == 0;
  if (!written) {
    if (write_errors_++ == 0) cli::warn(path_ + ": cannot append a received message (disk full?); recording goes on");
    return;
  }
  ++events_;
}

void EventRecorder::onMessage(void* tee, const char* channel, const uint8_t* data, std::size_t size) {
  auto* t = static_cast<Tee*>(tee);
  t->recorder->record(channel, data, size);
  if (t->next != nullptr) t->next(t->next_context, channel, data, size);
}

}  // namespace areomap::ground
