// The Mars 2020 raw-image record: as served (the model under "camera", the pixel frame under "extended",
// tuples written as strings "(a,b,c)", numbers often written as strings) and flattened by downloaders
// (camera_model_component_list, subframe_rect, scale_factor at the top level). The served form is read by
// lifting "camera" and "extended" to the top level under the flattened names; errors name the served
// field ("extended.subframeRect").
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "firmware_core/camera/CahvInternal.hpp"
#include "ground/io/CameraFileParts.hpp"
#include "ground/io/Pds3Label.hpp"
#include "ground/io/PixelFrame.hpp"

namespace areomap::io::detail {
namespace {

// The field names of each form, for messages.
struct FieldNames {
  std::string list, type, subframe, scale, dimension, sol, site, drive, attitude, xyz, sclk;
};
const FieldNames kFlatNames{"camera_model_component_list",
                            "camera_model_type",
                            "subframe_rect",
                            "scale_factor",
                            "dimension",
                            "sol",
                            "site",
                            "drive",
                            "attitude",
                            "xyz",
                            "sclk"};
const FieldNames kNestedNames{"camera.camera_model_component_list",
                              "camera.camera_model_type",
                              "extended.subframeRect",
                              "extended.scaleFactor",
                              "extended.dimension",
                              "sol",
                              "site",
                              "drive",
                              "attitude",
                              "extended.xyz",
                              "extended.sclk"};

// The served record with "camera" and "extended" lifted to the top level under the flattened names.
nlohmann::json flattened(const nlohmann::json& j) {
  nlohmann::json out = j;
  for (const auto& item : j["camera"].items()) out[item.key()] = item.value();
  if (j.contains("extended") && j["extended"].is_object()) {
    const std::pair<const char*, const char*> renames[] = {{"subframeRect", "subframe_rect"},
                                                           {"scaleFactor", "scale_factor"},
                                                           {"mastAz", "mast_az"},
                                                           {"mastEl", "mast_el"}};
    for (const auto& item : j["extended"].items()) {
      std::string key = item.key();
      for (const auto& r : renames) {
        if (key == r.first) key = r.second;
      }
      out[key] = item.value();
    }
  }
  return out;
}

// A number written as a number or as a string ("2", "702014201.641").
bool numberOf(const nlohmann::json& v, double& x) {
  if (v.is_number()) {
    x = v.get<double>();
    return std::isfinite(x);
  }
  if (!v.is_string()) return false;
  const std::string s = v.get<std::string>();
  char* end = nullptr;
  x = std::strtod(s.c_str(), &end);
  return end != s.c_str() && *end == '\0' && std::isfinite(x);
}

// The numbers of "(a,b,c)" or [a, b, c]; false when it is neither or an item is no number.
bool numbersOf(const nlohmann::json& v, std::vector<double>& out) {
  out.clear();
  if (v.is_array()) {
    for (const nlohmann::json& item : v) {
      double x = 0.0;
      if (!numberOf(item, x)) return false;
      out.push_back(x);
    }
    return true;
  }
  if (!v.is_string()) return false;
  for (const std::string& item : Pds3Label::tuple(v.get<std::string>())) {
    double x = 0.0;
    if (!numberOf(nlohmann::json(item), x)) return false;
    out.push_back(x);
  }
  return true;
}

// An optional integer field (sol, site, drive: a number or a string); absent or null leaves it unset.
std::optional<int> integerField(const nlohmann::json& j, const char* key, const std::string& path,
                                const std::string& field) {
  if (!j.contains(key) || j[key].is_null()) return std::nullopt;
  double x = 0.0;
  if (!numberOf(j[key], x) || !isCounter(x)) {
    throw cli::InputError(path, field, "expected an integer, found " + j[key].dump());
  }
  return static_cast<int>(x);
}

void readAcquisition(const nlohmann::json& j, const std::string& path, const FieldNames& names_of,
                     Acquisition& a) {
  if (j.contains("instrument") && j["instrument"].is_string())
    a.instrument = j["instrument"].get<std::string>();
  if (j.contains("imageid") && j["imageid"].is_string()) {
    a.product_id = j["imageid"].get<std::string>();
  } else {
    std::string stem = std::filesystem::path(path).filename().string();
    for (const char* suffix : {"-metadata.json", ".json"}) {
      const std::string s = suffix;
      if (stem.size() > s.size() && stem.compare(stem.size() - s.size(), s.size(), s) == 0) {
        stem.resize(stem.size() - s.size());
        break;
      }
    }
    a.product_id = stem;
  }
  // The raw-image service serves Mars 2020 only; the id's form says so too.
  a.mission = Mission::kM2020;
  a.sol = integerField(j, "sol", path, names_of.sol);
  a.site = integerField(j, "site", path, names_of.site);
  a.drive = integerField(j, "drive", path, names_of.drive);
  double x = 0.0;
  if (j.contains("sclk") && !j["sclk"].is_null()) {
    if (!numberOf(j["sclk"], x))
      throw cli::InputError(path, names_of.sclk, "expected a number, found " + j["sclk"].dump());
    a.sclk_s = x;
  }
  if (j.contains("mast_az") && numberOf(j["mast_az"], x)) a.mast_az_deg = x;
  if (j.contains("mast_el") && numberOf(j["mast_el"], x)) a.mast_el_deg = x;
  std::vector<double> v;
  if (j.contains("attitude") && !j["attitude"].is_null()) {
    const double norm = numbersOf(j["attitude"], v) && v.size() == 4
                            ? std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3])
                            : 0.0;
    if (!(std::fabs(norm - 1.0) < 1e-3)) {
      throw cli::InputError(path, names_of.attitude,
                            "expected a unit quaternion \"(s,v1,v2,v3)\", found " + j["attitude"].dump());
    }
    a.attitude = Eigen::Vector4d(v[0], v[1], v[2], v[3]) / norm;
  }
  a.rover_frame = "ROVER_NAV_FRAME";
  if (j.contains("xyz") && !j["xyz"].is_null()) {
    if (!numbersOf(j["xyz"], v) || v.size() != 3) {
      throw cli::InputError(path, names_of.xyz, "expected \"(x,y,z)\" in metres, found " + j["xyz"].dump());
    }
    a.xyz_m = Vec3(v[0], v[1], v[2]);
  }
}

// The first two numbers of "(1288,968)", [1288, 968] or [1, 1, 1288, 968].
bool pairOf(const nlohmann::json& j, double& a, double& b) {
  if (j.is_array() && j.size() >= 2 && j[0].is_number() && j[1].is_number()) {
    a = j[0].get<double>();
    b = j[1].get<double>();
    return true;
  }
  if (j.is_string()) {
    const std::vector<std::string> items = Pds3Label::tuple(j.get<std::string>());
    if (items.size() >= 2) {
      char* e1 = nullptr;
      char* e2 = nullptr;
      a = std::strtod(items[0].c_str(), &e1);
      b = std::strtod(items[1].c_str(), &e2);
      return e1 != items[0].c_str() && e2 != items[1].c_str();
    }
  }
  return false;
}

// The CAHV[OR[E]] model of camera_model_component_list (and camera_model_type), checked.
void parseM2020Model(const nlohmann::json& j, const std::string& path, const FieldNames& names_of,
                     CameraModel& m) {
  const char* const kList = "camera_model_component_list";
  const std::string& list_field = names_of.list;
  if (!j.contains(kList) || !j[kList].is_string())
    throw cli::InputError(path, list_field, "missing or not a string");
  std::vector<std::string> parts;
  {
    std::istringstream in(j[kList].get<std::string>());
    std::string part;
    while (std::getline(in, part, ';')) parts.push_back(part);
  }
  std::string type_name;
  if (j.contains("camera_model_type") && j["camera_model_type"].is_string()) {
    type_name = j["camera_model_type"].get<std::string>();
  } else {
    type_name = parts.size() >= 9 ? "CAHVORE" : parts.size() >= 6 ? "CAHVOR" : "CAHV";
  }
  m.type = typeFromName(type_name, path, names_of.type);
  const char* const names[] = {"C", "A", "H", "V", "O", "R", "E"};
  Vec3* targets[] = {&m.c, &m.a, &m.h, &m.v, &m.o, &m.r, &m.e};
  const int needed = componentCount(m.type) + (m.type == CameraType::kCahvore ? 2 : 0);
  if (static_cast<int>(parts.size()) < needed) {
    const std::string missing =
        parts.size() < 7 ? names[parts.size()] : (parts.size() == 7 ? "type" : "parameter");
    throw cli::InputError(
        path, list_field + " (" + missing + ")",
        "missing: " + std::to_string(parts.size()) + " components for a " + type_name + " model");
  }
  auto fieldOf = [&](const std::string& name) { return list_field + " (" + name + ")"; };
  for (int k = 0; k < componentCount(m.type); ++k) {
    *targets[k] = parseVector(Pds3Label::tuple(parts[static_cast<std::size_t>(k)]), path, fieldOf(names[k]));
  }
  if (m.type == CameraType::kCahvore) {
    setKind(m, parseNumber(Pds3Label::unquote(parts[7]), path, fieldOf("type")),
            parseNumber(Pds3Label::unquote(parts[8]), path, fieldOf("parameter")), path, fieldOf("type"));
  }
  validateOrThrow(m, path, fieldOf);
}

// scale_factor and the origin of subframe_rect ([first sample, first line, samples, lines], 1-based
// detector pixels). A scale_factor that is no integer in 1..kMaxDownsampling is ignored with a warning (the
// browse products' metadata is not always right, and the frame is decided without it when it must be).
void readM2020Metadata(const nlohmann::json& j, const std::string& path, const FieldNames& names_of,
                       FrameEvidence& e, CameraFile& out) {
  if (j.contains("scale_factor") && !j["scale_factor"].is_null()) {
    const nlohmann::json& s = j["scale_factor"];
    double v = 0.0;
    if (!numberOf(s, v)) v = 0.0;
    if (v >= 1.0 && v <= kMaxDownsampling && v == std::floor(v)) {
      e.meta_scale = static_cast<int>(v);
    } else {
      out.warnings.push_back(path + ": " + names_of.scale + " " + s.dump() + " is no integer in 1.." +
                             std::to_string(kMaxDownsampling) + ": ignored");
    }
  }
  if (j.contains("subframe_rect") && !j["subframe_rect"].is_null()) {
    double x = 0.0, y = 0.0;
    if (!pairOf(j["subframe_rect"], x, y)) {
      throw cli::InputError(path, names_of.subframe, "expected [first sample, first line, samples, lines]");
    }
    if (!(x >= 1.0 && x <= kMaxImageSidePx && y >= 1.0 && y <= kMaxImageSidePx)) {
      throw cli::InputError(
          path, names_of.subframe,
          "origin outside 1.." + std::to_string(kMaxImageSidePx) + " (1-based detector pixels)");
    }
    e.meta_origin_px = Vec2(x, y);
  }
}

}  // namespace

CameraFile fromM2020Json(const std::string& text, const std::string& path, int width, int height,
                         const DeliveredImage* image) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw cli::InputError(path, "json", e.what());
  }
  if (!j.is_object()) throw cli::InputError(path, "json", "expected an object");
  const bool nested = j.contains("camera") && j["camera"].is_object();
  const FieldNames names_of = nested ? kNestedNames : kFlatNames;
  if (nested) j = flattened(j);
  CameraFile out;
  out.format = CameraFileFormat::kM2020Json;
  // The record does not state the models' frame: the raw-image service gives them in the rover navigation
  // frame of the image's site and drive.
  out.reference_frame = "ROVER_NAV_FRAME";
  readAcquisition(j, path, names_of, out.acquisition);
  CameraModel& m = out.file_model;
  parseM2020Model(j, path, names_of, m);

  // The delivered image's size: the image's own, else "dimension", else the caller's.
  double w = width, h = height;
  std::string source = "given by the caller";
  double dim_w = 0.0, dim_h = 0.0;
  const bool has_dimension = j.contains("dimension") && pairOf(j["dimension"], dim_w, dim_h);
  if (has_dimension) {
    // Checked before it is narrowed to int32 (and multiplied by the scale below).
    if (!(dim_w >= 1.0 && dim_w <= kMaxImageSidePx && dim_h >= 1.0 && dim_h <= kMaxImageSidePx)) {
      throw cli::InputError(path, names_of.dimension,
                            "image size outside 1.." + std::to_string(kMaxImageSidePx) + " px");
    }
  }
  if (image != nullptr) {
    w = image->size.width;
    h = image->size.height;
    source = "from " + image->source;
    if (has_dimension && (dim_w != w || dim_h != h)) {
      out.warnings.push_back(path + ": dimension says " + std::to_string(std::lround(dim_w)) + "x" +
                             std::to_string(std::lround(dim_h)) + " but " + image->source + " is " +
                             std::to_string(image->size.width) + "x" + std::to_string(image->size.height) +
                             ": the image's size is used");
    }
    out.size_from_file = true;
  } else if (has_dimension) {
    w = dim_w;
    h = dim_h;
    source = "from its dimension";
    out.size_from_file = true;
  }
  m.width = static_cast<int32_t>(w);
  m.height = static_cast<int32_t>(h);
  out.model = m;
  if (!(w > 0 && h > 0)) return out;

  // The model's pixel frame (PixelFrame.hpp): a delivered pixel's centre lies at model pixel
  // offset + scale * pixel.
  FrameEvidence e;
  const CahvInternal internal = cahvInternal(m);
  e.principal_px = Vec2(internal.hc_px, internal.vc_px);
  e.width = m.width;
  e.height = m.height;
  readM2020Metadata(j, path, names_of, e, out);
  e.detector_px = knownDetector(out.acquisition.mission, out.acquisition.instrument);
  PixelFrame frame;
  std::string tried;
  if (!choosePixelFrame(e, frame, tried)) {
    char pp[64];
    std::snprintf(pp, sizeof pp, "(%.1f, %.1f)", e.principal_px.x(), e.principal_px.y());
    throw cli::InputError(path, names_of.list + " (H, V)",
                          std::string("the principal point ") + pp + " fits no pixel frame of the " +
                              std::to_string(m.width) + "x" + std::to_string(m.height) + " image (size " +
                              source + "); tried " + tried);
  }
  out.frame = frame.name;
  if (!frame.note.empty()) out.warnings.push_back(path + ": " + frame.note);
  out.scale = frame.scale;
  out.offset_px = frame.offset_px;
  out.model = rescaledModel(m, frame.scale, frame.offset_px, m.width, m.height);
  validateOrThrow(out.model, path, [&](const std::string& f) {
    return names_of.subframe + ", " + names_of.list + " (" + f + ")";
  });
  out.file_model.width = static_cast<int32_t>(std::lround(w * frame.scale));
  out.file_model.height = static_cast<int32_t>(std::lround(h * frame.scale));
  return out;
}

}  // namespace areomap::io::detail
