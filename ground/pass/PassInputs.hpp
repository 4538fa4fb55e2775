// What a ground pass is given besides its dataset when it runs at the end of a panorama received over
// LCM (ground/node): the camera stream's counts (report.json `stream`) and what the rover sent (its tie
// points, final EO, status; report.json `rover`). A pass on a dataset folder has neither.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "areomap/eo_solution_t.hpp"
#include "areomap/rover_status_t.hpp"
#include "ground/dataset/TruthFiles.hpp"

namespace areomap::ground {

// The `stream` object of report.json.
struct StreamCounts {
  int32_t pairs = 0;  // pairs kept
  int32_t gaps = 0;   // camera-stream messages never received
  int32_t duplicates = 0;
  int32_t reordered = 0;
  std::map<std::string, int32_t> rejected;  // cause -> count
  std::vector<std::string> warnings;        // gap-affected pairs, rover-channel losses, ...
  bool end_of_panorama = false;
  int32_t pairs_planned = -1;
};

// What the rover sent (absent when it did not run or nothing arrived).
struct RoverInputs {
  std::optional<eo_solution_t> eo;
  std::optional<rover_status_t> status;
  int32_t tie_messages = 0;
  int32_t tie_observations = 0;
  int32_t dem_messages = 0;
  std::vector<ImageObservation> ties;  // written as rover_tiepoints.csv
  std::set<int32_t> tie_pairs;         // pairs that a TIEPOINTS message came for
  int32_t tie_messages_missing = 0;    // TIEPOINTS sequence numbers never received
  bool finished = false;               // the rover's final EO (or FINISHED status) arrived
  std::vector<std::string> warnings;
};

}  // namespace areomap::ground
