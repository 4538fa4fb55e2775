// The camera stream of a dataset as areomap-pack makes it, with a fixed start time: shared by the pack,
// rover and ground-node tests so that they all see the same events.
#pragma once

#include <string>
#include <vector>

#include "ground/dataset/Dataset.hpp"
#include "ground/pack/Pack.hpp"

namespace areomap::test {

inline std::vector<LogEvent> packedStream(const std::string& dataset) {
  PackOptions options;
  options.start_utime = 1'700'000'000'000'000;
  return packDataset(readDataset(dataset), options);
}

}  // namespace areomap::test
