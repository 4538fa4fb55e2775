#include "ground/dataset/ModelFile.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

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
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw DatasetError(path, "", std::string("cannot write: ") + std::strerror(errno));
  out.write(buffer, static_cast<std::streamsize>(n));
  out.close();
  if (!out) throw DatasetError(path, "", "write failed");
}

}  // namespace areomap
