// Fuzz target: PDS3 products (ground/io): the label parser (Pds3Label::parse of the text up to the first
// NUL, as Pds3Label::read does), the IMAGE object and its body (readPds3ImageInfo, readPds3Image, loadImage8
// with the 16 -> 8 bit rule) and the camera model group (readCameraFile). The input is written to a file
// because the readers take paths. Expected failures are cli::InputError; any other exception, crash or
// sanitizer report is a bug.
// Invariant: an image that reads has the label's size.
#include <string>

#include <opencv2/core.hpp>

#include "ground/cli/Cli.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/io/ImageFile.hpp"
#include "ground/io/Pds3Label.hpp"
#include "tests/fuzz/FuzzSupport.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  using namespace areomap;
  static const std::string path = fuzz::scratchFolder() + "/input.IMG";
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    (void)io::Pds3Label::parse(text.substr(0, text.find('\0')), "input.IMG");
  } catch (const cli::InputError&) {
  }
  fuzz::writeFile(path, data, size);
  if (!io::isPds3File(path)) return 0;
  try {
    const io::Pds3ImageInfo info = io::readPds3ImageInfo(path);
    const cv::Mat gray = io::loadImage8(path);  // readPds3Image, then the 16 -> 8 bit rule
    if (gray.rows != info.lines || gray.cols != info.samples || gray.type() != CV_8UC1) {
      fuzz::fail("pds3", "loadImage8 size or type");
    }
  } catch (const cli::InputError&) {
  }
  try {
    const io::CameraFile camera = io::readCameraFile(path, 1024, 1024);
    fuzz::exerciseModel(camera.model, "pds3");
  } catch (const cli::InputError&) {
  }
  return 0;
}
