// A FileReader over files registered in memory (name -> bytes), for tests of code that reads files.
#pragma once

#include "platform/FileReader.hpp"

namespace areomap::platform {

class MemoryFileReader final : public FileReader {
 public:
  static constexpr int32_t kMaxFiles = 32;

  // Registers `path` (the pointer is kept, not copied) with its bytes. false when the table is full.
  bool add(const char* path, const uint8_t* data, std::size_t bytes);

  [[nodiscard]] Status fileSize(const char* path, std::size_t& bytes) override;
  [[nodiscard]] Status readAll(const char* path, uint8_t* out, std::size_t capacity_bytes,
                               std::size_t& bytes_read) override;

 private:
  struct File {
    const char* path;
    const uint8_t* data;
    std::size_t bytes;
  };
  const File* find(const char* path) const;
  int32_t num_files_ = 0;
  File files_[kMaxFiles] = {};
};

}  // namespace areomap::platform
