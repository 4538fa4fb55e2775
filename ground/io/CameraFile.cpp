#include "ground/io/CameraFile.hpp"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <fstream>
#include <sstream>
#include <vector>

#include <nlohmann/json.hpp>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/camera/CahvInternal.hpp"
#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/io/CameraFileParts.hpp"
#include "ground/io/GdalLabel.hpp"
#include "ground/io/ImageFile.hpp"
#include "ground/io/Pds3Label.hpp"
#include "ground/io/PixelFrame.hpp"

namespace areomap::io {
namespace {

using detail::DeliveredImage;

std::string readWhole(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw cli::InputError(path, "file", "cannot open");
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
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
    case CameraFileFormat::kJplText:
      return "jpl-text";
    case CameraFileFormat::kPds3:
      return "pds3";
    case CameraFileFormat::kM2020Json:
      return "m2020-json";
    case CameraFileFormat::kVicar:
      return "vicar";
    case CameraFileFormat::kPds4:
      return "pds4";
  }
  return "unknown";
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
  if (text[first] == '{') return detail::fromM2020Json(text, path, width, height, image);
  const std::string head = text.substr(0, std::min(text.size(), Pds3Label::kMaxBytes));
  if (head.find("PDS_VERSION_ID") != std::string::npos ||
      head.find("GEOMETRIC_CAMERA_MODEL") != std::string::npos) {
    return detail::fromPds3(Pds3Label::parse(head, path), width, height);
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
  return detail::fromPds3(label, width, height);
}

namespace {

// A VICAR or PDS4 product through GDAL; nullopt for another format.
std::optional<CameraFile> readThroughGdal(const std::string& path, int width, int height) {
  if (!isGdalLabelFile(path)) return std::nullopt;
  std::ifstream f(path, std::ios::binary);
  char head[8] = {};
  f.read(head, sizeof head);
  if (std::string(head, 8) == "LBLSIZE=") return readVicarCamera(path, width, height);
  return readPds4Camera(path, width, height);
}

}  // namespace

CameraFile readCameraFile(const std::string& path, int width, int height) {
  if (std::optional<CameraFile> gdal = readThroughGdal(path, width, height)) return *gdal;
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
  if (std::optional<CameraFile> gdal = readThroughGdal(path, width, height)) return *gdal;
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
