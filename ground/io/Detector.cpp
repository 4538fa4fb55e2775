#include "ground/io/Detector.hpp"

#include <algorithm>
#include <cctype>

namespace areomap::io {
namespace {

std::string upper(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return s;
}

bool has(const std::string& s, const char* part) {
  return s.find(part) != std::string::npos;
}

}  // namespace

const char* missionName(Mission mission) {
  switch (mission) {
    case Mission::kMer:
      return "MER";
    case Mission::kMsl:
      return "MSL";
    case Mission::kM2020:
      return "M2020";
    case Mission::kUnknown:
      break;
  }
  return "";
}

Mission missionFromHost(const std::string& host_in) {
  const std::string host = upper(host_in);
  if (host == "M20" || has(host, "2020") || has(host, "PERSEVERANCE")) return Mission::kM2020;
  if (has(host, "MSL") || has(host, "SCIENCE LABORATORY") || has(host, "CURIOSITY")) return Mission::kMsl;
  if (has(host, "MER") || has(host, "EXPLORATION ROVER") || has(host, "SPIRIT") || has(host, "OPPORTUNITY")) {
    return Mission::kMer;
  }
  return Mission::kUnknown;
}

Mission missionFromProductId(const std::string& id) {
  if (id.size() > 9 && id[3] == '_' && std::isalpha(static_cast<unsigned char>(id[0]))) {
    return id[8] == '_' ? Mission::kM2020 : Mission::kMsl;  // M2020: "NLF_0395_0702014201_..."
  }
  if (id.size() > 11 && (id[0] == '1' || id[0] == '2') && std::isalpha(static_cast<unsigned char>(id[1]))) {
    return Mission::kMer;
  }
  return Mission::kUnknown;
}

Vec2 knownDetector(Mission mission, const std::string& instrument_in) {
  const std::string instrument = upper(instrument_in);
  const bool engineering = has(instrument, "NAV") || has(instrument, "HAZ");
  switch (mission) {
    case Mission::kM2020:
      if (engineering) return Vec2(5120.0, 3840.0);
      break;
    case Mission::kMsl:
      if (engineering) return Vec2(1024.0, 1024.0);
      break;
    case Mission::kMer:
      if (engineering || has(instrument, "PANCAM")) return Vec2(1024.0, 1024.0);
      break;
    case Mission::kUnknown:
      break;
  }
  return Vec2::Zero();
}

}  // namespace areomap::io
