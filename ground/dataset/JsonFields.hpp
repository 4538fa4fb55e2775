// Reading and writing the JSON files of the dataset contract (panorama.json, traverse.json) with errors that
// name the file and the field. Used inside ground/dataset only (nlohmann_json is private to it).
#pragma once

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/DatasetError.hpp"

namespace areomap {

// Reads JSON fields with errors that name the file and the field.
class JsonFieldReader {
 public:
  explicit JsonFieldReader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const std::string& field, const std::string& message) const {
    throw DatasetError(file_, field, message);
  }

  int integer(const nlohmann::json& j, const std::string& field) const {
    if (j.is_number_integer() || j.is_number_unsigned()) {
      const long long v = j.get<long long>();
      if (v < -1000000000LL || v > 1000000000LL) fail(field, "integer out of range");
      return static_cast<int>(v);
    }
    if (j.is_number_float()) {
      const double d = j.get<double>();
      if (std::isfinite(d) && d == std::floor(d) && std::fabs(d) <= 1e9) return static_cast<int>(d);
    }
    fail(field, "expected an integer, got " + describe(j));
  }

  double number(const nlohmann::json& j, const std::string& field) const {
    if (!j.is_number()) fail(field, "expected a number, got " + describe(j));
    const double d = j.get<double>();
    if (!std::isfinite(d)) fail(field, "expected a finite number");
    return d;
  }

  Eigen::Vector3d vec3(const nlohmann::json& j, const std::string& field) const {
    if (!j.is_array() || j.size() != 3) fail(field, "expected an array [x, y, z] of 3 numbers");
    return Eigen::Vector3d(number(j[0], field + "[0]"), number(j[1], field + "[1]"),
                           number(j[2], field + "[2]"));
  }

  std::string string(const nlohmann::json& j, const std::string& field) const {
    if (!j.is_string()) fail(field, "expected a string, got " + describe(j));
    return j.get<std::string>();
  }

  std::string safePath(const nlohmann::json& j, const std::string& field) const {
    const std::string path = string(j, field);
    std::string why;
    if (!isSafeRelativePath(path, why)) fail(field, why + ": '" + path + "'");
    return path;
  }

  static std::string describe(const nlohmann::json& j) {
    if (j.is_null()) return "null";
    if (j.is_string()) return "a string";
    if (j.is_boolean()) return "a boolean";
    if (j.is_array()) return "an array";
    if (j.is_object()) return "an object";
    if (j.is_number()) return "a number (" + j.dump() + ")";
    return j.dump();
  }

 private:
  std::string file_;
};

inline std::string joinPath(const std::string& root, const std::string& relative) {
  if (root.empty()) return relative;
  if (root.back() == '/') return root + relative;
  return root + "/" + relative;
}

// The absolute, normalised path of a file under the dataset folder.
inline std::string resolvePath(const std::string& root, const std::string& relative) {
  std::error_code ec;
  std::filesystem::path base = std::filesystem::absolute(root.empty() ? std::string(".") : root, ec);
  if (ec) base = root;
  return (base / relative).lexically_normal().string();
}

// The top-level JSON object of `file`.
inline nlohmann::json parseJsonFile(const JsonFieldReader& r, const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) r.fail("", std::string("cannot open: ") + std::strerror(errno));
  nlohmann::json root;
  try {
    root = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception&
               e) {  // parse_error, and out_of_range for a number like 1e1111 (fuzz_panorama)
    r.fail("", std::string("not valid JSON: ") + e.what());
  }
  if (!root.is_object()) r.fail("", "expected a JSON object at the top level");
  return root;
}

// Writes `text` and a newline to `file` inside `dir` (created first). Throws DatasetError when it cannot.
inline void writeJsonFile(const std::string& dir, const std::string& file, const std::string& text) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw DatasetError(dir, "", "cannot create the folder: " + ec.message());
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) throw DatasetError(file, "", std::string("cannot write: ") + std::strerror(errno));
  out << text << '\n';
  out.close();
  if (!out) throw DatasetError(file, "", "write failed");
}

}  // namespace areomap
