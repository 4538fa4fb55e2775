#include "ground/traverse/SiteManifest.hpp"

#include <filesystem>
#include <fstream>
#include <vector>

#include <nlohmann/json.hpp>

#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Sha256.hpp"

namespace areomap::traverse {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

std::vector<cli::FileChecksum> siteFiles(const std::string& site_dir) {
  return cli::folderChecksums(site_dir, [](const std::string& rel) { return rel == kSiteManifestName; });
}

SiteRecord notComplete(const std::string& why) {
  SiteRecord r;
  r.why_not = why;
  return r;
}

}  // namespace

void writeSiteManifest(const std::string& site_dir, const std::string& site_id, bool mapped,
                       const std::string& error) {
  json files = json::array();
  for (const cli::FileChecksum& f : siteFiles(site_dir))
    files.push_back({{"name", f.name}, {"bytes", f.bytes}, {"sha256", f.sha256_hex}});
  const json manifest = {
      {"version", 1}, {"site", site_id}, {"mapped", mapped}, {"error", error}, {"files", files}};
  cli::writeFileAtomic(site_dir + "/" + kSiteManifestName, manifest.dump(1) + "\n");
}

SiteRecord checkSiteManifest(const std::string& site_dir, const std::string& site_id) {
  const std::string path = site_dir + "/" + kSiteManifestName;
  std::ifstream in(path);
  if (!in) return notComplete(std::string("no ") + kSiteManifestName);
  const json m = json::parse(in, nullptr, false);
  if (m.is_discarded() || !m.is_object() || m.value("version", 0) != 1 || !m.contains("files") ||
      !m["files"].is_array() || !m.contains("mapped") || !m["mapped"].is_boolean())
    return notComplete(std::string(kSiteManifestName) + " cannot be read");
  if (m.value("site", std::string()) != site_id)
    return notComplete(std::string(kSiteManifestName) + " is of site '" + m.value("site", std::string()) + "'");
  const std::vector<cli::FileChecksum> now = siteFiles(site_dir);
  if (now.size() != m["files"].size())
    return notComplete(std::to_string(now.size()) + " files, the manifest names " +
                       std::to_string(m["files"].size()));
  for (std::size_t i = 0; i < now.size(); ++i) {
    const json& f = m["files"][i];
    if (!f.is_object() || f.value("name", std::string()) != now[i].name)
      return notComplete(now[i].name + ": not in the manifest");
    if (f.value("bytes", int64_t{-1}) != now[i].bytes) return notComplete(now[i].name + ": size");
    if (f.value("sha256", std::string()) != now[i].sha256_hex) return notComplete(now[i].name + ": checksum");
  }
  SiteRecord r;
  r.complete = true;
  r.mapped = m["mapped"].get<bool>();
  r.error = m.value("error", std::string());
  return r;
}

}  // namespace areomap::traverse
