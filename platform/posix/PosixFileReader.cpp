#include "platform/posix/PosixFileReader.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>

namespace areomap::platform {
namespace {

// Bounds the read loop: a regular file is read in at most this many read() calls per MiB, plus one.
constexpr std::size_t kMaxReadCallsPerMiB = 1024;

class Fd {
 public:
  explicit Fd(const char* path) : fd_(::open(path, O_RDONLY | O_CLOEXEC)) {}
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }

 private:
  int fd_;
};

Status regularSize(int fd, std::size_t& bytes) {
  struct stat st {};
  if (fd < 0 || ::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) return Status::kIoError;
  bytes = static_cast<std::size_t>(st.st_size);
  return Status::kOk;
}

}  // namespace

Status PosixFileReader::fileSize(const char* path, std::size_t& bytes) {
  if (path == nullptr) return Status::kInvalidArgument;
  Fd fd(path);
  return regularSize(fd.get(), bytes);
}

Status PosixFileReader::readAll(const char* path, uint8_t* out, std::size_t capacity_bytes,
                                std::size_t& bytes_read) {
  bytes_read = 0;
  if (path == nullptr || (out == nullptr && capacity_bytes > 0)) return Status::kInvalidArgument;
  Fd fd(path);
  std::size_t size = 0;
  const Status status = regularSize(fd.get(), size);
  if (!ok(status)) return status;
  if (size > capacity_bytes) return Status::kCapacityExceeded;
  const std::size_t max_calls = (size / (1024 * 1024) + 1) * kMaxReadCallsPerMiB;
  for (std::size_t call = 0; call < max_calls && bytes_read < size; ++call) {
    const ssize_t n = ::read(fd.get(), out + bytes_read, size - bytes_read);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return n == 0 ? Status::kTruncated : Status::kIoError;  // file shrank / read error
    bytes_read += static_cast<std::size_t>(n);
  }
  return bytes_read == size ? Status::kOk : Status::kIoError;
}

}  // namespace areomap::platform
