// areomap-pack DATASET --out FILE.lcm: the camera stream of a dataset as a standard LCM event log.
#include <cstdio>
#include <filesystem>
#include <string>

#include "ground/cli/Cli.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/Traverse.hpp"
#include "ground/pack/Pack.hpp"

namespace {

constexpr const char* kUsage =
    "usage: areomap-pack DATASET|TRAVERSE --out FILE.lcm [--interval-s S] [--quality Q] [--start-utime US] "
    "[--inject SPEC]\n"
    "\n"
    "Writes the camera stream of a dataset folder as a standard LCM event log (what lcm-logger writes and\n"
    "lcm-logplayer plays): one AREOMAP_STEREO_PAIR event per pair in panorama.json order, with both images\n"
    "as 8-bit grey JPEG, both a-priori models (.cahvor or the PDS3 label), the rig (panorama.json, or\n"
    "estimated from the a-priori models and flagged), sequence numbers 0, 1, ..., and an end-of-panorama\n"
    "marker (kind END_OF_PANORAMA, sequence = number of pairs). Images: PNG/JPEG/PGM, 8/16-bit PDS3 .IMG;\n"
    "left-only pairs are sent with has_right false.\n"
    "\n"
    "A traverse folder (traverse.json, docs/traverse.md) gives one log of the whole traverse:\n"
    "for each site in driving order an AREOMAP_SITE announcement (site_t: id, index, a-priori pose, the "
    "odometry\n"
    "leg from the previous site, the panorama name its pairs carry, a last-site flag), then that site's "
    "pairs\n"
    "and its end-of-panorama marker as for the site alone (pair sequences from 0 per site). Sites that share "
    "a\n"
    "panorama name have their pairs named \"<traverse>/<site id>\" (a note says so).\n"
    "\n"
    "  --out FILE       the log to write\n"
    "  --interval-s S   seconds between pairs in the log timestamps (default 3)\n"
    "  --quality Q      JPEG quality 1..100 (default 95)\n"
    "  --start-utime US timestamp of the first event, microseconds since the epoch (default: now)\n"
    "  --inject SPEC    fault injection for tests, a comma list of: drop:S dup:S swap:S truncate:S\n"
    "                   corrupt-jpeg:S oversize:S nan-model:S unknown-channel wrong-type (S = a pair's "
    "sequence;\n"
    "                   in a traverse the first such pair) and drop-site:S dup-site:S truncate-site:S (S = "
    "a\n"
    "                   site announcement's sequence; see ground/pack/Pack.hpp)\n"
    "\n"
    "Exit: 0 ok, 2 usage error, 1 bad input (the message names the file and the field).\n";

}  // namespace

int main(int argc, char** argv) {
  return areomap::cli::runTool("areomap-pack", argc, argv, kUsage, [](areomap::cli::Args& args) {
    const std::string out = args.required("--out");
    areomap::PackOptions options;
    options.interval_s = args.number("--interval-s", options.interval_s);
    options.quality = static_cast<int>(args.integer("--quality", options.quality));
    options.start_utime = args.integer("--start-utime", 0);
    const std::string inject = args.option("--inject", "");
    const std::string dir = args.positional(0, "DATASET");
    const bool traverse = std::filesystem::is_regular_file(dir + "/" + areomap::kTraverseFileName) ||
                          std::filesystem::path(dir).filename() == areomap::kTraverseFileName;
    areomap::PackSummary summary;
    std::vector<areomap::LogEvent> events;
    std::size_t sites = 0;
    if (traverse) {
      const areomap::Traverse t = areomap::readTraverse(dir);
      areomap::checkTraverseSites(t);
      sites = t.sites.size();
      events = areomap::packTraverse(t, options, &summary);
    } else {
      const areomap::Dataset dataset = areomap::readDataset(dir);
      events = areomap::packDataset(dataset, options, &summary);
    }
    if (!inject.empty()) events = areomap::injectFaults(events, inject);
    areomap::writeEventLog(out, events);
    for (const std::string& n : summary.notes) areomap::cli::info(n);
    if (traverse) {
      std::printf(
          "packed %zu sites, %d pairs (%lld JPEG bytes), a site announcement and an end-of-panorama "
          "marker per site, %zu events: %s\n",
          sites, summary.pairs, static_cast<long long>(summary.jpeg_bytes), events.size(), out.c_str());
    } else {
      std::printf("packed %d pairs (%lld JPEG bytes) + end-of-panorama marker, %zu events: %s\n",
                  summary.pairs, static_cast<long long>(summary.jpeg_bytes), events.size(), out.c_str());
    }
    return 0;
  });
}
