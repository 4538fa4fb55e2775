// FileReader on open/fstat/read.
#pragma once

#include "platform/FileReader.hpp"

namespace areomap::platform {

class PosixFileReader final : public FileReader {
 public:
  [[nodiscard]] Status fileSize(const char* path, std::size_t& bytes) override;
  [[nodiscard]] Status readAll(const char* path, uint8_t* out, std::size_t capacity_bytes,
                               std::size_t& bytes_read) override;
};

}  // namespace areomap::platform
