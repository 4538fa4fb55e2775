// Products are never half-written: every product file is written under a temporary
// name in the same folder and renamed into place only when complete. A full disk or an unwritable folder
// gives an InputError naming the file, and leaves no partial file behind.
#pragma once

#include <cstddef>
#include <functional>
#include <string>

namespace areomap::cli {

// A temporary name beside `path` (same folder, so the final rename is atomic): "<path>.tmp-<pid>-<n>".
std::string temporaryPathFor(const std::string& path);

// Writes `size` bytes to `path` atomically (temporary file, fsync, rename).
void writeFileAtomic(const std::string& path, const void* data, std::size_t size);
void writeFileAtomic(const std::string& path, const std::string& text);

// For writers that need a file name (GDAL, OpenCV imwrite): `write(tmp_path)` writes the temporary file,
// which is then renamed to `path`; on any failure (an exception from `write`, or no file written) the
// temporary is removed and an InputError naming `path` (and the writer's message) is thrown. Writers
// must throw when their output is incomplete (check the stream after close, read a raster back).
void writeViaTemporary(const std::string& path, const std::function<void(const std::string& tmp_path)>& write);

}  // namespace areomap::cli
