#include "platform/stub/MemoryFileReader.hpp"

#include <cstring>

namespace areomap::platform {

bool MemoryFileReader::add(const char* path, const uint8_t* data, std::size_t bytes) {
  if (path == nullptr || num_files_ >= kMaxFiles) return false;
  files_[num_files_++] = File{path, data, bytes};
  return true;
}

const MemoryFileReader::File* MemoryFileReader::find(const char* path) const {
  for (int32_t i = 0; path != nullptr && i < num_files_; ++i) {
    if (std::strcmp(files_[i].path, path) == 0) return &files_[i];
  }
  return nullptr;
}

Status MemoryFileReader::fileSize(const char* path, std::size_t& bytes) {
  const File* file = find(path);
  if (file == nullptr) return Status::kIoError;
  bytes = file->bytes;
  return Status::kOk;
}

Status MemoryFileReader::readAll(const char* path, uint8_t* out, std::size_t capacity_bytes,
                                 std::size_t& bytes_read) {
  bytes_read = 0;
  if (path == nullptr || (out == nullptr && capacity_bytes > 0)) return Status::kInvalidArgument;
  const File* file = find(path);
  if (file == nullptr) return Status::kIoError;
  if (file->bytes > capacity_bytes) return Status::kCapacityExceeded;
  if (file->bytes > 0) std::memcpy(out, file->data, file->bytes);
  bytes_read = file->bytes;
  return Status::kOk;
}

}  // namespace areomap::platform
