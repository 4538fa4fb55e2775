#include "ground/io/CameraFile.hpp"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include <nlohmann/json.hpp>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/camera/CahvInternal.hpp"
#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/io/ImageFile.hpp"
#include "ground/io/Pds3Label.hpp"
#include "ground/io/PixelFrame.hpp"

namespace areomap::io {
namespace {

const char* const kGeometricGroups[] = {"GEOMETRIC_CAMERA_MODEL", "GEOMETRIC_CAMERA_MODEL_PARMS"};

std::string readWhole(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw cli::InputError(path, "file", "cannot open");
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

double parseNumber(const std::string& text, const std::string& file, const std::string& field) {
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (end == text.c_str()) throw cli::InputError(file, field, "expected a number, found '" + text + "'");
  while (*end == ' ' || *end == '\t') ++end;
  if (*end != '\0') throw cli::InputError(file, field, "expected a number, found '" + text + "'");
  if (!std::isfinite(x)) throw cli::InputError(file, field, "not a finite number ('" + text + "')");
  return x;
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

int componentCount(CameraType type) { return type == CameraType::kCahv ? 4 : (type == CameraType::kCahvor ? 6 : 7); }

void setKind(CameraModel& m, double type, double parameter, const std::string& file, const std::string& field) {
  if (type != 1.0 && type != 2.0 && type != 3.0) {
    throw cli::InputError(file, field, "CAHVORE type must be 1 (perspective), 2 (fisheye) or 3 (general)");
  }
  m.cahvore_kind = static_cast<CahvoreKind>(static_cast<int>(type));
  m.linearity = m.cahvore_kind == CahvoreKind::kPerspective ? 1.0
                : m.cahvore_kind == CahvoreKind::kFisheye  ? 0.0
                                                           : parameter;
}

// validateModel, with its field reported through `describe` (e.g. "MODEL_COMPONENT_2 (A)").
template <typename Describe>
void validateOrThrow(const CameraModel& m, const std::string& file, Describe describe) {
  const char* field = "";
  const Status s = validateModel(m, field);
  if (s == Status::kOk) return;
  const std::string f = field;
  std::string what = statusName(s);
  if (f == "A" || f == "O") what = s == Status::kInvalidArgument ? "must be a unit vector pointing forwards" : what;
  if ((f == "H" || f == "V") && s == Status::kDegenerate) what = "parallel to A (or H parallel to V)";
  if (s == Status::kNotFinite) what = "not a finite number";
  throw cli::InputError(file, describe(f), what);
}

CameraFile fromPds3(const Pds3Label& label, int width, int height) {
  const std::string& path = label.file();
  std::string group;
  for (const char* g : kGeometricGroups) {
    if (label.hasScope(g)) group = g;
  }
  if (group.empty()) throw cli::InputError(path, "GEOMETRIC_CAMERA_MODEL", "the label has no camera model group");
  CameraFile out;
  out.format = CameraFileFormat::kPds3;
  CameraModel& m = out.file_model;
  m.type = typeFromName(Pds3Label::unquote(label.required("MODEL_TYPE", group)), path, group + ".MODEL_TYPE");
  const std::vector<std::string> ids = Pds3Label::tuple(label.required("MODEL_COMPONENT_ID", group));
  const char* const names[] = {"C", "A", "H", "V", "O", "R", "E"};
  Vec3* targets[] = {&m.c, &m.a, &m.h, &m.v, &m.o, &m.r, &m.e};
  std::string component_of[7];
  double cahvore_type = 1.0, cahvore_parameter = 1.0;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const std::string key = "MODEL_COMPONENT_" + std::to_string(i + 1);
    const std::string field = group + "." + key + " (" + ids[i] + ")";
    const std::string* value = label.find(key, group);
    if (value == nullptr) throw cli::InputError(path, field, "missing");
    if (ids[i] == "T" || ids[i] == "P") {
      (ids[i] == "T" ? cahvore_type : cahvore_parameter) = parseNumber(Pds3Label::unquote(*value), path, field);
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
  if (m.type == CameraType::kCahvore) setKind(m, cahvore_type, cahvore_parameter, path, group + ".MODEL_COMPONENT (T)");
  if (const std::string* frame = label.find("REFERENCE_COORD_SYSTEM_NAME", group)) {
    out.reference_frame = Pds3Label::unquote(*frame);
  }
  if (label.find("LINES", "IMAGE") != nullptr && label.find("LINE_SAMPLES", "IMAGE") != nullptr) {
    const long samples = label.integer("LINE_SAMPLES", "IMAGE"), lines = label.integer("LINES", "IMAGE");
    if (samples <= 0 || lines <= 0 || samples > kMaxImageSidePx || lines > kMaxImageSidePx) {
      throw cli::InputError(path, "IMAGE.LINES", "image size outside 1.." + std::to_string(kMaxImageSidePx) + " px");
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

// The delivered image's size when an image tells it (the image beside the file, or the caller's), and
// which image that was, for warnings and errors.
struct DeliveredImage {
  ImageSize size;
  std::string source;
};

// The CAHV[OR[E]] model of camera_model_component_list (and camera_model_type), checked.
void parseM2020Model(const nlohmann::json& j, const std::string& path, CameraModel& m) {
  const char* const kList = "camera_model_component_list";
  if (!j.contains(kList) || !j[kList].is_string())
    throw cli::InputError(path, kList, "missing or not a string");
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
  m.type = typeFromName(type_name, path, "camera_model_type");
  const char* const names[] = {"C", "A", "H", "V", "O", "R", "E"};
  Vec3* targets[] = {&m.c, &m.a, &m.h, &m.v, &m.o, &m.r, &m.e};
  const int needed = componentCount(m.type) + (m.type == CameraType::kCahvore ? 2 : 0);
  if (static_cast<int>(parts.size()) < needed) {
    const std::string missing = parts.size() < 7 ? names[parts.size()] : (parts.size() == 7 ? "type" : "parameter");
    throw cli::InputError(path, std::string(kList) + " (" + missing + ")",
                          "missing: " + std::to_string(parts.size()) + " components for a " + type_name + " model");
  }
  auto fieldOf = [&](const std::string& name) { return std::string(kList) + " (" + name + ")"; };
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
void readM2020Metadata(const nlohmann::json& j, const std::string& path, FrameEvidence& e, CameraFile& out) {
  if (j.contains("scale_factor") && !j["scale_factor"].is_null()) {
    const nlohmann::json& s = j["scale_factor"];
    const double v = s.is_number() ? s.get<double>() : 0.0;
    if (v >= 1.0 && v <= kMaxDownsampling && v == std::floor(v)) {
      e.meta_scale = static_cast<int>(v);
    } else {
      out.warnings.push_back(path + ": scale_factor " + s.dump() + " is no integer in 1.." +
                             std::to_string(kMaxDownsampling) + ": ignored");
    }
  }
  if (j.contains("subframe_rect") && !j["subframe_rect"].is_null()) {
    double x = 0.0, y = 0.0;
    if (!pairOf(j["subframe_rect"], x, y)) {
      throw cli::InputError(path, "subframe_rect", "expected [first sample, first line, samples, lines]");
    }
    if (!(x >= 1.0 && x <= kMaxImageSidePx && y >= 1.0 && y <= kMaxImageSidePx)) {
      throw cli::InputError(
          path, "subframe_rect",
          "origin outside 1.." + std::to_string(kMaxImageSidePx) + " (1-based detector pixels)");
    }
    e.meta_origin_px = Vec2(x, y);
  }
}

CameraFile fromM2020Json(const std::string& text, const std::string& path, int width, int height,
                         const DeliveredImage* image) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw cli::InputError(path, "json", e.what());
  }
  CameraFile out;
  out.format = CameraFileFormat::kM2020Json;
  CameraModel& m = out.file_model;
  parseM2020Model(j, path, m);

  // The delivered image's size: the image's own, else "dimension", else the caller's.
  double w = width, h = height;
  std::string source = "given by the caller";
  double dim_w = 0.0, dim_h = 0.0;
  const bool has_dimension = j.contains("dimension") && pairOf(j["dimension"], dim_w, dim_h);
  if (has_dimension) {
    // Checked before it is narrowed to int32 (and multiplied by the scale below).
    if (!(dim_w >= 1.0 && dim_w <= kMaxImageSidePx && dim_h >= 1.0 && dim_h <= kMaxImageSidePx)) {
      throw cli::InputError(path, "dimension", "image size outside 1.." + std::to_string(kMaxImageSidePx) + " px");
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
  readM2020Metadata(j, path, e, out);
  PixelFrame frame;
  std::string tried;
  if (!choosePixelFrame(e, frame, tried)) {
    char pp[64];
    std::snprintf(pp, sizeof pp, "(%.1f, %.1f)", e.principal_px.x(), e.principal_px.y());
    throw cli::InputError(path, "camera_model_component_list (H, V)",
                          std::string("the principal point ") + pp + " fits no pixel frame of the " +
                              std::to_string(m.width) + "x" + std::to_string(m.height) + " image (size " +
                              source + "); tried " + tried);
  }
  out.frame = frame.name;
  out.scale = frame.scale;
  out.offset_px = frame.offset_px;
  out.model = rescaledModel(m, frame.scale, frame.offset_px, m.width, m.height);
  validateOrThrow(out.model, path, [](const std::string& f) {
    return "subframe_rect, camera_model_component_list (" + f + ")";
  });
  out.file_model.width = static_cast<int32_t>(std::lround(w * frame.scale));
  out.file_model.height = static_cast<int32_t>(std::lround(h * frame.scale));
  return out;
}

CameraFile fromJplText(const std::string& text, const std::string& path, int width, int height) {
  CameraFile out;
  out.format = CameraFileFormat::kJplText;
  const char* field = "";
  const Status s = parseModelText(text.data(), text.size(), out.file_model, field);
  if (s != Status::kOk) {
    std::string what = s == Status::kMissingField ? "missing" : statusName(s);
    if (s == Status::kCorruptData) what = "expected numbers (truncated or malformed line)";
    if (s == Status::kNotFinite) what = "not a finite number";
    if (s == Status::kInvalidArgument && (std::string(field) == "A" || std::string(field) == "O")) {
      what = "must be a unit vector pointing forwards";
    }
    if (s == Status::kDegenerate) what = "parallel to A (or H parallel to V)";
    throw cli::InputError(path, field, what);
  }
  if (out.file_model.width > 0 && out.file_model.height > 0) {
    out.size_from_file = true;
  } else {
    out.file_model.width = width;
    out.file_model.height = height;
  }
  out.model = out.file_model;
  return out;
}

}  // namespace

const char* formatName(CameraFileFormat format) {
  switch (format) {
    case CameraFileFormat::kJplText: return "jpl-text";
    case CameraFileFormat::kPds3: return "pds3";
    case CameraFileFormat::kM2020Json: return "m2020-json";
  }
  return "unknown";
}

CameraModel rescaledModel(const CameraModel& model, double scale, const Vec2& offset_px, int width, int height) {
  CameraModel m = model;
  m.h = (model.h - offset_px.x() * model.a) / scale;
  m.v = (model.v - offset_px.y() * model.a) / scale;
  m.width = width;
  m.height = height;
  return m;
}

namespace {

bool looksLikeJson(const std::string& text) {
  const std::size_t first = text.find_first_not_of(" \t\r\n");
  return first != std::string::npos && text[first] == '{';
}

CameraFile parseText(const std::string& text, const std::string& path, int width, int height,
                     const DeliveredImage* image) {
  std::size_t first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) throw cli::InputError(path, "file", "empty");
  if (text[first] == '{') return fromM2020Json(text, path, width, height, image);
  const std::string head = text.substr(0, std::min(text.size(), Pds3Label::kMaxBytes));
  if (head.find("PDS_VERSION_ID") != std::string::npos || head.find("GEOMETRIC_CAMERA_MODEL") != std::string::npos) {
    return fromPds3(Pds3Label::parse(head, path), width, height);
  }
  return fromJplText(text, path, width, height);
}

std::string readText(const std::string& path) {
  std::string text = readWhole(path);
  // An attached PDS3 label is followed by binary image data: keep the text part.
  const std::size_t nul = text.find('\0');
  if (nul != std::string::npos) text.resize(nul);
  return text;
}

void warnAll(const CameraFile& file) {
  for (const std::string& w : file.warnings) cli::warn(w);
}

}  // namespace

std::string imageBeside(const std::string& path) {
  const std::filesystem::path p(path);
  std::string stem = p.filename().string();
  for (const char* suffix : {"-metadata.json", ".json"}) {
    const std::size_t n = std::strlen(suffix);
    if (stem.size() > n && stem.compare(stem.size() - n, n, suffix) == 0) {
      stem.resize(stem.size() - n);
      for (const char* ext : {".png", ".PNG", ".jpg", ".JPG", ".jpeg", ".JPEG", ".pgm", ".PGM", ".ppm",
                              ".tif", ".tiff", ".TIF", ".IMG", ".img"}) {
        const std::filesystem::path candidate = p.parent_path() / (stem + ext);
        std::error_code ec;
        if (std::filesystem::is_regular_file(candidate, ec)) return candidate.string();
      }
      return "";
    }
  }
  return "";
}

CameraFile parseCameraText(const std::string& text, const std::string& path, int width, int height) {
  return parseText(text, path, width, height, nullptr);
}

CameraFile readPds3Camera(const Pds3Label& label, int width, int height) {
  return fromPds3(label, width, height);
}

CameraFile readCameraFile(const std::string& path, int width, int height) {
  const std::string text = readText(path);
  if (looksLikeJson(text)) {
    const std::string image = imageBeside(path);
    if (!image.empty()) {
      const DeliveredImage delivered{readImageSize(image), image};
      return parseText(text, path, width, height, &delivered);
    }
  }
  return parseText(text, path, width, height, nullptr);
}

CameraFile readCameraFileForImage(const std::string& path, const std::string& image_path, int width,
                                  int height) {
  const std::string text = readText(path);
  if (!looksLikeJson(text)) return parseText(text, path, width, height, nullptr);
  const DeliveredImage delivered{
      width > 0 && height > 0 ? ImageSize{width, height} : readImageSize(image_path), image_path};
  return parseText(text, path, width, height, &delivered);
}

CameraModel readCameraModelFile(const std::string& path, int width, int height) {
  const CameraFile file = readCameraFile(path, width, height);
  warnAll(file);
  return file.model;
}

CameraModel readCameraModelForImage(const std::string& path, const std::string& image_path, int width,
                                    int height) {
  const CameraFile file = readCameraFileForImage(path, image_path, width, height);
  warnAll(file);
  return file.model;
}

void writeCameraModelFile(const std::string& path, const CameraModel& model) {
  char buffer[kModelTextBytes];
  const std::size_t n = formatModelText(model, buffer, sizeof buffer);
  if (n == 0) throw cli::InputError(path, "model", "does not fit the text buffer");
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);  // a failure shows in the write
  cli::writeFileAtomic(path, buffer, n);  // temporary name, fsync, rename: whole or not at all
}

}  // namespace areomap::io
