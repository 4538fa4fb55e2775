// The ground node's record of what it received (for kill-and-resume): every message the node
// takes from a live transport is appended to an LCM event log (the format lcm-logger writes and
// `areomap-ground --lcm file://LOG` reads) and flushed to the kernel before it is handled, so a node killed
// at any moment (SIGKILL included) leaves a log of everything it had received; a trailing half-written
// event is dropped by the reader (kTruncated). A restarted node re-makes the same products from it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

#include "platform/Transport.hpp"

namespace areomap::ground {

// The recording's name in the node's --out folder (left out of the product manifest).
inline constexpr const char* kRecordingName = "received.lcm";

class EventRecorder {
 public:
  EventRecorder() = default;
  ~EventRecorder();
  EventRecorder(const EventRecorder&) = delete;
  EventRecorder& operator=(const EventRecorder&) = delete;

  // Creates (truncates) the log. Throws cli::InputError naming the path when it cannot.
  void open(const std::string& path);
  bool isOpen() const { return file_ != nullptr; }
  // Appends one event stamped with the wall clock; a write error is counted (the node keeps running).
  void record(const char* channel, const uint8_t* data, std::size_t size);
  int64_t events() const { return events_; }
  int64_t writeErrors() const { return write_errors_; }

  // A platform::MessageHandler that records, then hands the message on to `next` (context: the Tee).
  struct Tee {
    EventRecorder* recorder = nullptr;
    platform::MessageHandler next = nullptr;
    void* next_context = nullptr;
  };
  static void onMessage(void* tee, const char* channel, const uint8_t* data, std::size_t size);

 private:
  std::FILE* file_ = nullptr;
  std::string path_;
  int64_t events_ = 0;
  int64_t write_errors_ = 0;
};

}  // namespace areomap::ground
