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
    throw DatasetError::from(path, e);
  }
}

}  // namespace areomap
