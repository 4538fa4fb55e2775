#include "ground/dataset/DatasetFile.hpp"

#include <filesystem>

#include "ground/cli/AtomicFile.hpp"

namespace areomap {

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
