#include "ground/dataset/DatasetError.hpp"

namespace areomap {
namespace {

std::string compose(const std::string& file, const std::string& field, const std::string& message) {
  std::string text = file;
  if (!field.empty()) text += ": " + field;
  return text + ": " + message;
}

}  // namespace

DatasetError::DatasetError(const std::string& file, const std::string& field, const std::string& message)
    : std::runtime_error(compose(file, field, message)), file_(file), field_(field), message_(message) {}

}  // namespace areomap
