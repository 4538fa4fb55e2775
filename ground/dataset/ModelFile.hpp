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

// Every dataset writer (models, truth CSVs) writes whole or not at all: `text` goes to a temporary name
// beside `path` (parent folder created), is synced and renamed into place (ground/cli AtomicFile). A failed
// write (full disk, folder not writable) throws DatasetError naming `path` and leaves the previous file, or
// none, never a partial one.
void writeDatasetFile(const std::string& path, const std::string& text);

}  // namespace areomap
