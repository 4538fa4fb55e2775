// Whole-or-nothing writes of a dataset's text files (truth CSVs, tie lists). The camera model files of a
// dataset (`models/<stem>.cahvor`, `truth/models/<stem>.cahvor`) are read and written by ground/io's
// CameraFile (readCameraModelFile, writeCameraModelFile), the one reader of every camera format.
#pragma once

#include <string>

#include "ground/dataset/DatasetError.hpp"

namespace areomap {

// Every dataset writer writes whole or not at all: `text` goes to a temporary name beside `path` (parent
// folder created), is synced and renamed into place (ground/cli AtomicFile). A failed write (full disk,
// folder not writable) throws DatasetError naming `path` and leaves the previous file, or none, never a
// partial one.
void writeDatasetFile(const std::string& path, const std::string& text);

}  // namespace areomap
