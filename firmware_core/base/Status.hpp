// Status codes of the rover side. No exceptions in firmware_core: every function that can fail on data
// returns a [[nodiscard]] Status; asserts are for programmer errors only.
#pragma once

#include <cstdint>

namespace areomap {

enum class Status : uint8_t {
  kOk = 0,
  kInvalidArgument,   // a value outside its documented domain (caller or data)
  kMissingField,      // a required field or component is absent
  kNotFinite,         // NaN or infinity in input data
  kDegenerate,        // geometry that cannot be solved (parallel vectors, singular normal matrix)
  kBehindCamera,      // a point that does not project (behind or on the image plane)
  kNoConvergence,     // an iteration reached its bound without meeting its tolerance
  kCapacityExceeded,  // input larger than a named capacity (Capacities.hpp)
  kCorruptData,       // bytes that do not decode (JPEG, message, label)
  kTruncated,         // input ends early
  kUnsupported,       // a valid but unsupported variant (model type, sample type)
  kNoTexture,         // an image without usable texture (blank, saturated, noise only)
  kIoError,           // the operating system refused (platform layer only)
  kTimeout,           // nothing arrived in time (platform layer only)
  kEndOfStream,       // a log replay reached its end (platform layer only)
  kCount              // number of codes; not a status
};

// A stable, lowercase name for logs, reports and telemetry ("ok", "capacity_exceeded", ...).
const char* statusName(Status status);

inline bool ok(Status status) { return status == Status::kOk; }

}  // namespace areomap
