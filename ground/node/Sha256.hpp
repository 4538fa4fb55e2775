// SHA-256 (FIPS 180-4) of files and byte strings, for the product manifest (AREOMAP_PRODUCT). Written
// here rather than taken from OpenSSL so that the ground node needs no further package.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace areomap::ground {

class Sha256 {
 public:
  Sha256();
  void update(const void* data, std::size_t size);
  std::string hexDigest();  // 64 lowercase hex digits; ends the hash (call once)

 private:
  void block(const uint8_t* p);
  uint32_t h_[8];
  uint8_t buffer_[64];
  std::size_t buffered_ = 0;
  uint64_t total_bytes_ = 0;
};

std::string sha256Hex(const std::string& bytes);
// Throws cli::InputError(path, "file", ...) when the file cannot be read.
std::string sha256File(const std::string& path);

}  // namespace areomap::ground
