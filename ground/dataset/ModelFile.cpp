#include "ground/dataset/ModelFile.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "ground/cli/AtomicFile.hpp"

namespace areomap {

CameraModel readModelFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw DatasetError(path, "", std::string("cannot open: ") + std::strerror(errno));
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  CameraModel model;
  const char* field = "";
  const Status status = parseModelText(text.data(), text.size(), model, field);
  if (status != Status::kOk) {
    throw DatasetError(path, field != nullptr ? field : "", std::string("not a valid camera model (") + statusName(status) + ")");
  }
  return model;
}

void writeModelFile(const std::string& path, const CameraModel& model) {
  char buffer[4096];
  const std::size_t n = formatModelText(model, buffer, sizeof(buffer));
  if (n == 0) throw DatasetError(path, "", "camera model does not format");
  writeDatasetFile(path, std::string(buffer, n));
}

void writeDatasetFile(const std::string& path, const std::string& text) {
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  try {
    cli::writeFileAtomic(path, text);
  } catch (const cli::InputError& e) {
    // writeFileAtomic's message is "<path>: <what>"; a DatasetError names the file the same way.
    const std::string what = e.what();
    const std::string prefix = path + ": ";
    throw DatasetError(path, "", what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what);
  }
}

}  // namespace areomap
