// Small helpers of the dataset tests.
#pragma once

#include <fstream>
#include <string>

namespace areomap::test {

inline void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
}

inline bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace areomap::test
