// Fuzz target: camera model text. The core's parser (parseModelText: the rover-side reader of the JPL
// .cahvor form, no heap, no exceptions) and ground/io parseCameraText, which tells the JPL text form, a
// PDS3 label (GEOMETRIC_CAMERA_MODEL group) and the Mars 2020 metadata JSON apart by content. Expected
// failures: a Status (core) and cli::InputError (ground). Every model that parses goes through
// fuzz::exerciseModel (projection, back-projection, text round trip); a downsampled M2020 model also.
#include <string>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/io/CameraFile.hpp"
#include "tests/fuzz/FuzzSupport.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  using namespace areomap;
  CameraModel core;
  const char* field = "";
  if (ok(parseModelText(reinterpret_cast<const char*>(data), size, core, field))) {
    fuzz::exerciseModel(core, "camera_file");
  }
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const io::CameraFile file = io::parseCameraText(text, "input", 1024, 1024);
    fuzz::exerciseModel(file.file_model, "camera_file");
    fuzz::exerciseModel(file.model, "camera_file");
  } catch (const cli::InputError&) {
  }
  return 0;
}
