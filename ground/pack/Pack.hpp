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
//   oversize:S       replace that pair's left image with a 1100 x 1100 one (cause capacity_exceeded)
//   nan-model:S      a NaN in that pair's left a-priori model (cause not_finite)
//   unknown-channel  an extra event on channel AREOMAP_UNKNOWN (not subscribed: ignored)
//   wrong-type       an extra rover_status_t on the AREOMAP_STEREO_PAIR channel (cause unsupported)
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "ground/dataset/Dataset.hpp"

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
std::vector<LogEvent> packDataset(const Dataset& dataset, const PackOptions& options, PackSummary* summary = nullptr);

// Applies a fault SPEC (above) to a packed stream. Throws cli::UsageError for a bad SPEC.
std::vector<LogEvent> injectFaults(const std::vector<LogEvent>& events, const std::string& spec);

// Writes the events as an LCM event log. Throws cli::InputError when the file cannot be written.
void writeEventLog(const std::string& path, const std::vector<LogEvent>& events);

}  // namespace areomap
