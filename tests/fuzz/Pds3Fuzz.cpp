// Fuzz target: PDS3 products (ground/io): the label parser (Pds3Label::parse of the text up to the first
// NUL and at most Pds3Label::kMaxBytes, as Pds3Label::read does), the IMAGE object and its body
// (readPds3ImageInfo, readPds3Image8: readPds3Image with the 16 -> 8 bit rule of loadImage8) and the camera
// model group (readPds3Camera, what readCameraFile does with a label). The label is parsed once per input,
// from memory; the input is written to a file only when it parsed (the image body and a detached data file
// are read from files). Expected failures are cli::InputError; any other exception, crash or sanitizer
// report is a bug.
// Invariants: the parse does linear work (Pds3ParseWork::balance_chars <= the text's size); an image that
// reads has the label's size.
#include <algorithm>
#include <cstring>
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
  const void* nul = std::memchr(data, '\0', size);
  const std::size_t text_size =
      std::min(nul != nullptr ? static_cast<std::size_t>(static_cast<const uint8_t*>(nul) - data) : size,
               io::Pds3Label::kMaxBytes);
  const std::string text(reinterpret_cast<const char*>(data), text_size);
  io::Pds3Label label;
  io::Pds3ParseWork work;
  bool parsed = true;
  try {
    label = io::Pds3Label::parse(text, path, &work);
  } catch (const cli::InputError&) {
    parsed = false;
  }
  if (work.balance_chars > text.size()) fuzz::fail("pds3", "the label parse does more than linear work");
  if (!parsed) return 0;
  fuzz::writeFile(path, data, size);
  try {
    const io::Pds3ImageInfo info = io::readPds3ImageInfo(label);
    const cv::Mat gray = io::readPds3Image8(info);
    if (gray.rows != info.lines || gray.cols != info.samples || gray.type() != CV_8UC1) {
      fuzz::fail("pds3", "readPds3Image8 size or type");
    }
  } catch (const cli::InputError&) {
  }
  try {
    const io::CameraFile camera = io::readPds3Camera(label, 1024, 1024);
    fuzz::exerciseModel(camera.model, "pds3");
  } catch (const cli::InputError&) {
  }
  return 0;
}
