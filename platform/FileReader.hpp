// Reading whole files into caller buffers (rover: fixed buffers allocated at start-up).
#pragma once

#include <cstddef>
#include <cstdint>

#include "firmware_core/base/Status.hpp"

namespace areomap::platform {

class FileReader {
 public:
  virtual ~FileReader() = default;

  // Size of the file at path. kIoError when it cannot be opened (missing, no permission, a directory).
  [[nodiscard]] virtual Status fileSize(const char* path, std::size_t& bytes) = 0;

  // Reads the whole file into out. kIoError when it cannot be opened or read, kCapacityExceeded when it is
  // larger than capacity_bytes (nothing useful is in out then), kInvalidArgument for null pointers.
  [[nodiscard]] virtual Status readAll(const char* path, uint8_t* out, std::size_t capacity_bytes,
                                       std::size_t& bytes_read) = 0;
};

}  // namespace areomap::platform
