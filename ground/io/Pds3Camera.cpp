// The camera model group of a PDS3 label (and of a VICAR label, which GdalLabel.cpp hands over in PDS3
// form): GROUP = GEOMETRIC_CAMERA_MODEL (MER) or GEOMETRIC_CAMERA_MODEL_PARMS (MSL, Mars 2020) with
// MODEL_TYPE, MODEL_COMPONENT_ID and MODEL_COMPONENT_1..n, the CAHVORE type and parameter either named in
// MODEL_COMPONENT_ID ("T", "P") or written after the seven vectors as components 8 and 9; the model's
// REFERENCE_COORD_SYSTEM_NAME; and what the label says of the exposure and of the rover.
#include <cmath>
#include <string>
#include <vector>

#include "ground/io/CameraFileParts.hpp"
#include "ground/io/Pds3Label.hpp"

namespace areomap::io::detail {
namespace {

const char* const kGeometricGroups[] = {"GEOMETRIC_CAMERA_MODEL", "GEOMETRIC_CAMERA_MODEL_PARMS"};
// MER writes the rover's pose in ROVER_COORDINATE_SYSTEM, MSL and Mars 2020 in ..._PARMS.
const char* const kRoverGroups[] = {"ROVER_COORDINATE_SYSTEM", "ROVER_COORDINATE_SYSTEM_PARMS"};

// MODEL_COMPONENT_<n+1> and <n+2> after n listed vectors: the CAHVORE type and parameter, when present.
void readTypeComponents(const Pds3Label& label, const std::string& group, std::size_t listed, double& type,
                        double& parameter) {
  const std::string type_key = "MODEL_COMPONENT_" + std::to_string(listed + 1);
  const std::string parameter_key = "MODEL_COMPONENT_" + std::to_string(listed + 2);
  if (const std::string* t = label.find(type_key, group)) {
    type = parseNumber(Pds3Label::unquote(*t), label.file(), group + "." + type_key + " (type)");
  }
  if (const std::string* p = label.find(parameter_key, group)) {
    parameter =
        parseNumber(Pds3Label::unquote(*p), label.file(), group + "." + parameter_key + " (parameter)");
  }
}

std::optional<double> optionalNumber(const Pds3Label& label, const char* key, const std::string& scope) {
  const std::string* v = label.find(key, scope);
  if (v == nullptr) return std::nullopt;
  std::string text = Pds3Label::unquote(*v);
  // Clock counts may carry a partition prefix ("1/0702014201.641").
  const std::size_t slash = text.find('/');
  if (slash != std::string::npos) text = text.substr(slash + 1);
  return parseNumber(text, label.file(), key);
}

// A counter (sol, site, drive) read as a number: whole and within int's range, else the label is refused.
int labelCounter(double x, const std::string& path, const std::string& field) {
  if (!isCounter(x)) {
    throw cli::InputError(path, field, "expected a whole number below 1e9, found " + std::to_string(x));
  }
  return static_cast<int>(x);
}

void readAcquisition(const Pds3Label& label, const std::string& camera_group, Acquisition& a) {
  const std::string& path = label.file();
  if (const std::string* v = label.find("INSTRUMENT_ID", "*")) a.instrument = Pds3Label::unquote(*v);
  if (const std::string* v = label.find("PRODUCT_ID", "*")) a.product_id = Pds3Label::unquote(*v);
  for (const char* key : {"INSTRUMENT_HOST_ID", "INSTRUMENT_HOST_NAME", "MISSION_NAME"}) {
    if (a.mission != Mission::kUnknown) break;
    if (const std::string* v = label.find(key, "*")) a.mission = missionFromHost(Pds3Label::unquote(*v));
  }
  if (a.mission == Mission::kUnknown) a.mission = missionFromProductId(a.product_id);
  if (const auto sol = optionalNumber(label, "PLANET_DAY_NUMBER", "*")) {
    a.sol = labelCounter(*sol, path, "PLANET_DAY_NUMBER");
  }
  a.sclk_s = optionalNumber(label, "SPACECRAFT_CLOCK_START_COUNT", "*");
  // Site and drive: the rover motion counter, else the camera model frame's index.
  const std::string* counter = label.find("ROVER_MOTION_COUNTER", "*");
  const std::string* counter_names = label.find("ROVER_MOTION_COUNTER_NAME", "*");
  if (counter == nullptr) {
    counter = label.find("REFERENCE_COORD_SYSTEM_INDEX", camera_group);
    counter_names = nullptr;
  }
  if (counter != nullptr) {
    const std::vector<std::string> values = Pds3Label::tuple(*counter);
    std::vector<std::string> names =
        counter_names ? Pds3Label::tuple(*counter_names) : std::vector<std::string>{};
    if (names.empty()) names = {"SITE", "DRIVE"};
    for (std::size_t i = 0; i < values.size() && i < names.size(); ++i) {
      const std::string name = Pds3Label::unquote(names[i]);
      if (name != "SITE" && name != "DRIVE") continue;
      const double x = parseNumber(values[i], path, "ROVER_MOTION_COUNTER (" + name + ")");
      (name == "SITE" ? a.site : a.drive) = labelCounter(x, path, "ROVER_MOTION_COUNTER (" + name + ")");
    }
  }
  for (const char* group : kRoverGroups) {
    if (!label.hasScope(group)) continue;
    const std::string* q = label.find("ORIGIN_ROTATION_QUATERNION", group);
    const std::string* t = label.find("ORIGIN_OFFSET_VECTOR", group);
    if (q != nullptr) {
      const std::vector<std::string> items = Pds3Label::tuple(*q);
      const std::string field = std::string(group) + ".ORIGIN_ROTATION_QUATERNION";
      if (items.size() != 4) throw cli::InputError(path, field, "expected 4 numbers");
      Eigen::Vector4d v;
      for (int k = 0; k < 4; ++k) v(k) = parseNumber(items[static_cast<std::size_t>(k)], path, field);
      if (!(std::fabs(v.norm() - 1.0) < 1e-3)) throw cli::InputError(path, field, "not a unit quaternion");
      a.attitude = v / v.norm();
    }
    if (t != nullptr)
      a.xyz_m = parseVector(Pds3Label::tuple(*t), path, std::string(group) + ".ORIGIN_OFFSET_VECTOR");
    if (const std::string* name = label.find("COORDINATE_SYSTEM_NAME", group))
      a.rover_frame = Pds3Label::unquote(*name);
    if (a.rover_frame.empty()) a.rover_frame = "ROVER_FRAME";
  }
}

}  // namespace

CameraFile fromPds3(const Pds3Label& label, int width, int height) {
  const std::string& path = label.file();
  std::string group;
  for (const char* g : kGeometricGroups) {
    if (label.hasScope(g)) group = g;
  }
  if (group.empty())
    throw cli::InputError(path, "GEOMETRIC_CAMERA_MODEL", "the label has no camera model group");
  CameraFile out;
  out.format = CameraFileFormat::kPds3;
  CameraModel& m = out.file_model;
  m.type = typeFromName(Pds3Label::unquote(label.required("MODEL_TYPE", group)), path, group + ".MODEL_TYPE");
  const std::vector<std::string> ids = Pds3Label::tuple(label.required("MODEL_COMPONENT_ID", group));
  const char* const names[] = {"C", "A", "H", "V", "O", "R", "E"};
  Vec3* targets[] = {&m.c, &m.a, &m.h, &m.v, &m.o, &m.r, &m.e};
  std::string component_of[7];
  double cahvore_type = 1.0, cahvore_parameter = 1.0;
  bool has_type = false;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const std::string key = "MODEL_COMPONENT_" + std::to_string(i + 1);
    const std::string field = group + "." + key + " (" + ids[i] + ")";
    const std::string* value = label.find(key, group);
    if (value == nullptr) throw cli::InputError(path, field, "missing");
    if (ids[i] == "T" || ids[i] == "P") {
      has_type = has_type || ids[i] == "T";
      (ids[i] == "T" ? cahvore_type : cahvore_parameter) =
          parseNumber(Pds3Label::unquote(*value), path, field);
      continue;
    }
    for (int k = 0; k < 7; ++k) {
      if (ids[i] == names[k]) {
        *targets[k] = parseVector(Pds3Label::tuple(*value), path, field);
        component_of[k] = key;
      }
    }
  }
  for (int k = 0; k < componentCount(m.type); ++k) {
    if (component_of[k].empty()) {
      throw cli::InputError(path, group + ".MODEL_COMPONENT_ID",
                            std::string("has no component ") + names[k] + " for a " +
                                Pds3Label::unquote(*label.find("MODEL_TYPE", group)) + " model");
    }
  }
  if (m.type == CameraType::kCahvore) {
    // MSL and Mars 2020 list seven ids (C..E) and write the type and parameter as components 8 and 9.
    if (!has_type) readTypeComponents(label, group, ids.size(), cahvore_type, cahvore_parameter);
    setKind(m, cahvore_type, cahvore_parameter, path, group + ".MODEL_COMPONENT (T)");
  }
  if (const std::string* frame = label.find("REFERENCE_COORD_SYSTEM_NAME", group)) {
    out.reference_frame = Pds3Label::unquote(*frame);
    out.reference_frame_stated = true;
  }
  readAcquisition(label, group, out.acquisition);
  if (label.find("LINES", "IMAGE") != nullptr && label.find("LINE_SAMPLES", "IMAGE") != nullptr) {
    const long samples = label.integer("LINE_SAMPLES", "IMAGE"), lines = label.integer("LINES", "IMAGE");
    if (samples <= 0 || lines <= 0 || samples > kMaxImageSidePx || lines > kMaxImageSidePx) {
      throw cli::InputError(path, "IMAGE.LINES",
                            "image size outside 1.." + std::to_string(kMaxImageSidePx) + " px");
    }
    m.width = static_cast<int32_t>(samples);
    m.height = static_cast<int32_t>(lines);
    out.size_from_file = true;
  } else {
    m.width = width;
    m.height = height;
  }
  validateOrThrow(m, path, [&](const std::string& f) {
    for (int k = 0; k < 7; ++k) {
      if (f == names[k] && !component_of[k].empty()) return group + "." + component_of[k] + " (" + f + ")";
    }
    return group + " (" + f + ")";
  });
  out.model = m;
  return out;
}

}  // namespace areomap::io::detail
