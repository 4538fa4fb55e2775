// The product manifest of a pass: every file the ground wrote for a panorama with its size and SHA-256,
// and the AREOMAP_PRODUCT message that publishes it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "areomap/product_t.hpp"
#include "ground/cli/Sha256.hpp"

namespace areomap::ground {

// A file: its name relative to the out dir, size and SHA-256.
using ManifestEntry = cli::FileChecksum;

// Every file under out_dir (recursively, sorted), except `exclude_prefix` ("" = none) and the node's
// recording (kRecordingName at the top).
std::vector<ManifestEntry> buildManifest(const std::string& out_dir, const std::string& exclude_prefix = "");
product_t manifestMessage(const std::string& panorama, const std::string& out_dir,
                          const std::vector<ManifestEntry>& files, int64_t sequence);

}  // namespace areomap::ground
