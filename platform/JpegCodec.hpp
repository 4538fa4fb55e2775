// JPEG decoding into caller-provided fixed buffers (rover) and encoding (areomap-pack), 8-bit grayscale.
// A corrupt, truncated or over-capacity JPEG gives a status, never a crash.
#pragma once

#include <cstddef>
#include <cstdint>

#include "firmware_core/base/Status.hpp"

namespace areomap::platform {

class JpegCodec {
 public:
  virtual ~JpegCodec() = default;

  // Reads the header, checks width*height against capacity_bytes, then decodes to 8-bit gray (row-major,
  // no padding) into out. width/height are set from the header whenever it parses (also on
  // kCapacityExceeded). Statuses: kInvalidArgument (null pointers), kTruncated (the data ends before the
  // image does), kCorruptData (not a JPEG or damaged), kCapacityExceeded (image larger than capacity_bytes),
  // kUnsupported (a codec that failed to start).
  [[nodiscard]] virtual Status decodeGray(const uint8_t* jpeg, std::size_t jpeg_bytes, uint8_t* out,
                                          std::size_t capacity_bytes, int32_t& width, int32_t& height) = 0;

  // decodeGray binned by `bin` (1..kMaxBinning) while it decodes (firmware_core/base/LineBinner.hpp):
  // floor(width / bin) x floor(height / bin) pixels, each the rounded mean of a bin x bin block, into out;
  // width/height are the header's (full-resolution) size. kInvalidArgument for a bin outside
  // 1..kMaxBinning; kCapacityExceeded when the binned image exceeds capacity_bytes or kMaxImageWidth
  // columns (nothing decoded then). bin 1 is decodeGray.
  [[nodiscard]] virtual Status decodeGrayBinned(const uint8_t* jpeg, std::size_t jpeg_bytes, int32_t bin,
                                                uint8_t* out, std::size_t capacity_bytes, int32_t& width,
                                                int32_t& height) = 0;

  // Encodes width x height 8-bit gray pixels at quality 1..100 into out (capacity_bytes); sets
  // encoded_bytes. kCapacityExceeded when out is too small (maxEncodedBytes() is always enough).
  [[nodiscard]] virtual Status encodeGray(const uint8_t* pixels, int32_t width, int32_t height,
                                          int32_t quality, uint8_t* out, std::size_t capacity_bytes,
                                          std::size_t& encoded_bytes) = 0;

  // An upper bound of the encoded size of a width x height gray image at any quality.
  virtual std::size_t maxEncodedBytes(int32_t width, int32_t height) const = 0;
};

}  // namespace areomap::platform
