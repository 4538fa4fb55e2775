#include "ground/node/Manifest.hpp"

#include <algorithm>
#include <filesystem>

#include "ground/cli/Cli.hpp"
#include "ground/node/EventRecorder.hpp"
#include "ground/node/Sha256.hpp"

namespace areomap::ground {

namespace fs = std::filesystem;

std::vector<ManifestEntry> buildManifest(const std::string& out_dir, const std::string& exclude_prefix) {
  std::vector<ManifestEntry> files;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(out_dir)) {
    if (!e.is_regular_file()) continue;
    const std::string rel = fs::relative(e.path(), out_dir).generic_string();
    if (!exclude_prefix.empty() && rel.rfind(exclude_prefix, 0) == 0) continue;
    if (rel == kRecordingName) continue;
    if (rel.find(".tmp-") != std::string::npos) continue;
    files.push_back(ManifestEntry{rel, static_cast<int64_t>(e.file_size()), sha256File(e.path().string())});
  }
  std::sort(files.begin(), files.end(),
            [](const ManifestEntry& a, const ManifestEntry& b) { return a.name < b.name; });
  return files;
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
