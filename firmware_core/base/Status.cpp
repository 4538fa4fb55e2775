#include "firmware_core/base/Status.hpp"

namespace areomap {

const char* statusName(Status status) {
  switch (status) {
    case Status::kOk: return "ok";
    case Status::kInvalidArgument: return "invalid_argument";
    case Status::kMissingField: return "missing_field";
    case Status::kNotFinite: return "not_finite";
    case Status::kDegenerate: return "degenerate";
    case Status::kBehindCamera: return "behind_camera";
    case Status::kNoConvergence: return "no_convergence";
    case Status::kCapacityExceeded: return "capacity_exceeded";
    case Status::kCorruptData: return "corrupt_data";
    case Status::kTruncated: return "truncated";
    case Status::kUnsupported: return "unsupported";
    case Status::kNoTexture: return "no_texture";
    case Status::kIoError: return "io_error";
    case Status::kTimeout: return "timeout";
    case Status::kEndOfStream: return "end_of_stream";
    case Status::kCount: break;
  }
  return "unknown";
}

}  // namespace areomap
