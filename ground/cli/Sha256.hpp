// SHA-256 (FIPS 180-4) of files and byte strings, for the product manifests (the ground node's
// AREOMAP_PRODUCT, a traverse site's manifest.json). Written here rather than taken from OpenSSL so that the
// ground needs no further package.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace areomap::cli {

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

// A file of a folder's manifest: its path relative to the folder, size and SHA-256.
struct FileChecksum {
  std::string name;
  int64_t bytes = 0;
  std::string sha256_hex;
};

// Every regular file under `dir` (recursively, sorted by name) but the temporary files of the atomic
// writers (".tmp-", AtomicFile.hpp) and those `skip` refuses (given the relative name; null: none).
std::vector<FileChecksum> folderChecksums(const std::string& dir,
                                          const std::function<bool(const std::string& name)>& skip = nullptr);

}  // namespace areomap::cli
