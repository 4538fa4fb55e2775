// A traverse site's manifest: OUT/sites/<id>/manifest.json, the last file a site's pass writes (in every
// way areomap-traverse runs it: in the process, as a child process, as a Slurm task). It records how the
// pass ended (mapped, or not mapped for its data and why) and every file of the site's folder with its size
// and SHA-256. A site counts as done only when its manifest is there and every file it names is there
// with that size and checksum: a pass killed part way (no manifest yet), a file written again since, or
// a file gone leaves the site to be mapped again (--resume), never half used.
//
//   {"version": 1, "site": "site02", "mapped": true, "error": "",
//    "files": [{"name": "eo.csv", "bytes": 1234, "sha256": "..."}, ...]}
#pragma once

#include <string>

namespace areomap::traverse {

inline constexpr const char* kSiteManifestName = "manifest.json";

// Writes `site_dir`/manifest.json (atomically) over every file now in `site_dir`. Throws InputError when
// it cannot be written.
void writeSiteManifest(const std::string& site_dir, const std::string& site_id, bool mapped,
                       const std::string& error);

struct SiteRecord {
  bool complete = false;  // the manifest is there and every file matches it
  std::string why_not;    // when not complete: the first mismatch ("no manifest.json", "eo.csv: checksum")
  bool mapped = false;    // as the manifest says (complete only)
  std::string error;      // why the site was not mapped (complete, not mapped)
};

// The site's state from its manifest, checking every file's size and checksum.
SiteRecord checkSiteManifest(const std::string& site_dir, const std::string& site_id);

}  // namespace areomap::traverse
