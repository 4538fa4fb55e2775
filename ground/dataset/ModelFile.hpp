// Camera model files of a dataset (`models/<stem>.cahvor`, `truth/models/<stem>.cahvor`) in the JPL text
// form, read and written through the core's parser and formatter, with errors that name the file and the
// component.
#pragma once

#include <string>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/DatasetError.hpp"

namespace areomap {

// Throws DatasetError("<path>", "<component>", "...") when the file is missing or does not parse.
CameraModel readModelFile(const std::string& path);
// Creates the parent folder; throws DatasetError when the file cannot be written.
void writeModelFile(const std::string& path, const CameraModel& model);

}  // namespace areomap
