// Reading a tool's output files in the traverse tests: report.json, and a CSV's line count; where the
// TraverseTool group's run is.
#pragma once

#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

namespace areomap::test {

// The TraverseTool group's default run (TraverseToolTest.cpp: areomap-traverse with products on a 2-site
// tiny traverse of 4 pairs a site, seed 3, legs of 10-12 m), in these folders of the build tree's
// test-scratch: its dataset (under /ds) and its output. CTest runs that group as the fixture
// `traverse_tool_run` of the stream traverse tests (tests/ground/node/CMakeLists.txt), which then compare
// with that run instead of making the same one again (AREOMAP_TRAVERSE_TOOL_RUN=1).
inline constexpr const char* kTraverseToolDataset = "traverse-tool";
inline constexpr const char* kTraverseToolOut = "traverse-tool-out";

// The JSON file at `path` (a discarded value when it does not parse).
inline nlohmann::json readJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in, nullptr, false);
}

inline int lines(const std::string& path) {
  std::ifstream in(path);
  int n = 0;
  for (std::string l; std::getline(in, l);) ++n;
  return n;
}

}  // namespace areomap::test
