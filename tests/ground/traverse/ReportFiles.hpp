// Reading a tool's output files in the traverse tests: report.json, and a CSV's line count.
#pragma once

#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

namespace areomap::test {

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
