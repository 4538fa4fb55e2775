// Internal to ground/io: the pieces that the camera-file readers of each format share (numbers and vectors
// with the file and field in errors, model types, CAHVORE kinds, model validation) and the readers of the
// formats that live in their own files. Not for use outside ground/io.
#pragma once

#include <string>
#include <vector>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/io/ImageFile.hpp"
#include "ground/io/Pds3Label.hpp"

namespace areomap::io::detail {

double parseNumber(const std::string& text, const std::string& file, const std::string& field);
// Whether x can be a counter of the records (sol, site, drive): a whole number within +-1e9, so that it
// narrows to int.
bool isCounter(double x);
Vec3 parseVector(const std::vector<std::string>& items, const std::string& file, const std::string& field);
CameraType typeFromName(const std::string& name, const std::string& file, const std::string& field);
int componentCount(CameraType type);
// CAHVORE type 1 (perspective), 2 (fisheye), 3 (general, linearity = parameter).
void setKind(CameraModel& m, double type, double parameter, const std::string& file,
             const std::string& field);

// validateModel, with its field reported through `describe` (e.g. "MODEL_COMPONENT_2 (A)").
template <typename Describe>
void validateOrThrow(const CameraModel& m, const std::string& file, Describe describe) {
  const char* field = "";
  const Status s = validateModel(m, field);
  if (s == Status::kOk) return;
  const std::string f = field;
  std::string what = statusName(s);
  if (f == "A" || f == "O")
    what = s == Status::kInvalidArgument ? "must be a unit vector pointing forwards" : what;
  if ((f == "H" || f == "V") && s == Status::kDegenerate) what = "parallel to A (or H parallel to V)";
  if (s == Status::kNotFinite) what = "not a finite number";
  throw cli::InputError(file, describe(f), what);
}

// The delivered image's size when an image tells it (the image beside the file, or the caller's), and
// which image that was, for warnings and errors.
struct DeliveredImage {
  ImageSize size;
  std::string source;
};

// The camera model group of a PDS3 label, or of a VICAR label in PDS3 form (Pds3Camera.cpp).
CameraFile fromPds3(const Pds3Label& label, int width, int height);

// The Mars 2020 raw-image record, as served (nested "camera" / "extended") or flattened (M2020Record.cpp).
CameraFile fromM2020Json(const std::string& text, const std::string& path, int width, int height,
                         const DeliveredImage* image);

}  // namespace areomap::io::detail
