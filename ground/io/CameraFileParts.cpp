#include "ground/io/CameraFileParts.hpp"

#include <cmath>
#include <cstdlib>

namespace areomap::io::detail {

double parseNumber(const std::string& text, const std::string& file, const std::string& field) {
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (end == text.c_str()) throw cli::InputError(file, field, "expected a number, found '" + text + "'");
  while (*end == ' ' || *end == '\t') ++end;
  if (*end != '\0') throw cli::InputError(file, field, "expected a number, found '" + text + "'");
  if (!std::isfinite(x)) throw cli::InputError(file, field, "not a finite number ('" + text + "')");
  return x;
}

bool isCounter(double x) {
  return std::isfinite(x) && x == std::floor(x) && std::fabs(x) <= 1e9;
}

Vec3 parseVector(const std::vector<std::string>& items, const std::string& file, const std::string& field) {
  if (items.size() != 3) {
    throw cli::InputError(file, field, "expected 3 numbers, found " + std::to_string(items.size()));
  }
  return Vec3(parseNumber(items[0], file, field), parseNumber(items[1], file, field),
              parseNumber(items[2], file, field));
}

CameraType typeFromName(const std::string& name, const std::string& file, const std::string& field) {
  if (name == "CAHV") return CameraType::kCahv;
  if (name == "CAHVOR") return CameraType::kCahvor;
  if (name == "CAHVORE") return CameraType::kCahvore;
  throw cli::InputError(file, field, "unsupported camera model type '" + name + "' (CAHV, CAHVOR, CAHVORE)");
}

int componentCount(CameraType type) {
  return type == CameraType::kCahv ? 4 : (type == CameraType::kCahvor ? 6 : 7);
}

void setKind(CameraModel& m, double type, double parameter, const std::string& file,
             const std::string& field) {
  if (type != 1.0 && type != 2.0 && type != 3.0) {
    throw cli::InputError(file, field, "CAHVORE type must be 1 (perspective), 2 (fisheye) or 3 (general)");
  }
  m.cahvore_kind = static_cast<CahvoreKind>(static_cast<int>(type));
  m.linearity = m.cahvore_kind == CahvoreKind::kPerspective ? 1.0
                : m.cahvore_kind == CahvoreKind::kFisheye   ? 0.0
                                                            : parameter;
}

}  // namespace areomap::io::detail
