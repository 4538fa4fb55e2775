// Shared by the fuzz targets (tests/fuzz/*Fuzz.cpp): the libFuzzer entry point, a per-process scratch
// folder for the readers that take a path, and the one way a target reports a broken invariant.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "firmware_core/camera/CameraModel.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size);

namespace areomap::fuzz {

// A folder of this process under $TMPDIR (or /tmp), made on first use: readers that take a path get the
// input written there (libFuzzer's -fork/-jobs workers each have their own).
const std::string& scratchFolder();

// Writes data[0, size) to `path` (replacing it); aborts when the file cannot be written (not an input error).
void writeFile(const std::string& path, const uint8_t* data, std::size_t size);

// A broken invariant: prints `what` and aborts, which libFuzzer (and the replay main) report as a crash.
[[noreturn]] void fail(const char* target, const char* what);

// What every decoded camera model must survive: projection of a point ahead, back-projection of the
// image centre, and the text form round trip (formatModelText -> parseModelText gives the same numbers).
void exerciseModel(const CameraModel& model, const char* target);

}  // namespace areomap::fuzz
