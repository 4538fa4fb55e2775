#include "ground/node/Manifest.hpp"

#include "ground/cli/Cli.hpp"
#include "ground/node/EventRecorder.hpp"

namespace areomap::ground {

std::vector<ManifestEntry> buildManifest(const std::string& out_dir, const std::string& exclude_prefix) {
  return cli::folderChecksums(out_dir, [&](const std::string& rel) {
    return (!exclude_prefix.empty() && rel.rfind(exclude_prefix, 0) == 0) || rel == kRecordingName;
  });
}

product_t manifestMessage(const std::string& panorama, const std::string& out_dir,
                          const std::vector<ManifestEntry>& files, int64_t sequence) {
  product_t m;
  m.utime = static_cast<int64_t>(cli::nowSeconds() * 1e6);
  m.sequence = sequence;
  m.panorama = panorama;
  m.out_dir = out_dir;
  m.num_files = static_cast<int32_t>(files.size());
  for (const ManifestEntry& f : files) {
    m.names.push_back(f.name);
    m.bytes.push_back(f.bytes);
    m.sha256_hex.push_back(f.sha256_hex);
  }
  return m;
}

}  // namespace areomap::ground
