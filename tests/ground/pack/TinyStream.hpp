// The camera stream of a dataset as areomap-pack makes it, with a fixed start time: shared by the pack,
// rover and ground-node tests so that they all see the same events.
#pragma once

#include <string>
#include <vector>

#include "ground/dataset/Dataset.hpp"
#include "ground/pack/Pack.hpp"
#include "tests/support/TestData.hpp"

namespace areomap::test {

inline std::vector<LogEvent> packedStream(const std::string& dataset) {
  PackOptions options;
  options.start_utime = 1'700'000'000'000'000;
  return packDataset(readDataset(dataset), options);
}

// The tiny simulated panorama (8 pairs) of the pack tests, made once per process (empty when it could not
// be made), and its stream.
inline const std::string& tinyPackDataset() {
  static const std::string dir = makeTinyDataset("pack-tiny");
  return dir;
}

inline const std::vector<LogEvent>& tinyPackStream() {
  static const std::vector<LogEvent> events = packedStream(tinyPackDataset());
  return events;
}

}  // namespace areomap::test
