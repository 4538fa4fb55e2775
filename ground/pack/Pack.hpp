// areomap-pack: a dataset folder -> the camera stream as a standard LCM event log (the format lcm-logger
// writes and lcm-logplayer plays): one AREOMAP_STEREO_PAIR event per pair in panorama.json order, utime
// spaced by interval_s, both images JPEG-compressed (platform codec, 8-bit grey), both a-priori models, rig
// values from panorama.json or estimated from the a-priori models (flags false), sequence numbers 0, 1, ...
// and a final KIND_END_OF_PANORAMA message (sequence = number of pairs).
//
// Fault injection for the node tests (injectFaults, `areomap-pack --inject SPEC`), SPEC a comma list:
//   drop:S           remove the pair with sequence S (a gap)
//   dup:S            send the pair with sequence S twice (a duplicate)
//   swap:S           swap the pairs with sequences S and S+1 (S+1 arrives out of order)
//   truncate:S       cut that pair's message to half its bytes (cause truncated)
//   corrupt-jpeg:S   damage the left JPEG's header of that pair (cause corrupt_data)
//   oversize:S       replace that pair's left image with one wider than the rover can bin into its
//                    capacity, kMaxBinnedSourceWidth + 1 px (cause capacity_exceeded)
//   nan-model:S      a NaN in that pair's left a-priori model (cause not_finite)
//   unknown-channel  an extra event on channel AREOMAP_UNKNOWN (not subscribed: ignored)
//   wrong-type       an extra rover_status_t on the AREOMAP_STEREO_PAIR channel (cause unsupported)
// and for a traverse stream (S = a site announcement's sequence, i.e. the site's index):
//   drop-site:S      remove that site's announcement (its pairs then name a panorama no site announced)
//   dup-site:S       announce that site a second time (same id and panorama, a new sequence) after it
//   truncate-site:S  cut that site's announcement to half its bytes (cause truncated)
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/Traverse.hpp"

namespace areomap {

struct PackOptions {
  double interval_s = 3.0;  // between pairs, like a mast stepping from one pointing to the next
  int quality = 95;
  int64_t start_utime = 0;  // of the first event; 0 = now
};

struct LogEvent {
  std::string channel;
  int64_t utime = 0;
  std::vector<uint8_t> data;
};

struct PackSummary {
  int pairs = 0;
  int64_t jpeg_bytes = 0;
  std::vector<std::string> notes;  // what was estimated
};

// The stream of a dataset. Throws cli::InputError naming the file and field for unreadable inputs.
std::vector<LogEvent> packDataset(const Dataset& dataset, const PackOptions& options,
                                  PackSummary* summary = nullptr);

// The stream of a multi-site traverse (traverse.json): for each site in driving order one AREOMAP_SITE
// announcement (site_t, sequence = the site's index), then that site's pairs and its end-of-panorama marker
// exactly as packDataset writes them for the site alone (AREOMAP_STEREO_PAIR sequences 0, 1, ... per site,
// as a sender that starts a new panorama numbers them). The pairs' panorama name is the site dataset's name
// (panorama.json); when two sites share a name (or a site has none) every site's pairs are named
// "<traverse name>/<site id>" instead, and a note says so. utime runs on over the whole traverse, with one
// interval between sites. Throws cli::InputError naming the file and field for unreadable inputs.
std::vector<LogEvent> packTraverse(const Traverse& traverse, const PackOptions& options,
                                   PackSummary* summary = nullptr);

// The panorama name of each site's pairs in packTraverse's stream (in site order), and whether they had to
// be qualified as "<traverse name>/<site id>".
std::vector<std::string> traversePanoramaNames(const Traverse& traverse, bool* qualified = nullptr);

// Applies a fault SPEC (above) to a packed stream. Throws cli::UsageError for a bad SPEC.
std::vector<LogEvent> injectFaults(const std::vector<LogEvent>& events, const std::string& spec);

// Writes the events as an LCM event log. Throws cli::InputError when the file cannot be written.
void writeEventLog(const std::string& path, const std::vector<LogEvent>& events);

}  // namespace areomap
