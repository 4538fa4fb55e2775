#include "platform/posix/TurboJpegCodec.hpp"

#include <turbojpeg.h>

#include <climits>
#include <cstdio>
#include <vector>

#include "firmware_core/base/LineBinner.hpp"

namespace areomap::platform {
namespace {

// A JPEG that does not end with the EOI marker (FF D9) was cut short.
bool endsWithEoi(const uint8_t* jpeg, std::size_t bytes) {
  return bytes >= 2 && jpeg[bytes - 2] == 0xFF && jpeg[bytes - 1] == 0xD9;
}

bool startsWithSoi(const uint8_t* jpeg, std::size_t bytes) {
  return bytes >= 2 && jpeg[0] == 0xFF && jpeg[1] == 0xD8;
}

}  // namespace

TurboJpegCodec::~TurboJpegCodec() {
  if (decompressor_ != nullptr) tjDestroy(decompressor_);
  if (compressor_ != nullptr) tjDestroy(compressor_);
}

Status TurboJpegCodec::open() {
  if (decompressor_ == nullptr) decompressor_ = tjInitDecompress();
  if (compressor_ == nullptr) compressor_ = tjInitCompress();
  return decompressor_ != nullptr && compressor_ != nullptr ? Status::kOk : Status::kUnsupported;
}

void TurboJpegCodec::rememberError(void* handle) {
  std::snprintf(last_error_, sizeof(last_error_), "%s", tjGetErrorStr2(handle));
}

Status TurboJpegCodec::decodeGray(const uint8_t* jpeg, std::size_t jpeg_bytes, uint8_t* out,
                                  std::size_t capacity_bytes, int32_t& width, int32_t& height) {
  width = 0;
  height = 0;
  last_error_[0] = '\0';
  if (jpeg == nullptr || out == nullptr) return Status::kInvalidArgument;
  if (decompressor_ == nullptr) return Status::kUnsupported;
  if (jpeg_bytes > static_cast<std::size_t>(ULONG_MAX)) return Status::kCapacityExceeded;
  if (!startsWithSoi(jpeg, jpeg_bytes)) return Status::kCorruptData;
  const auto size = static_cast<unsigned long>(jpeg_bytes);
  int w = 0;
  int h = 0;
  int subsampling = 0;
  int colorspace = 0;
  if (tjDecompressHeader3(decompressor_, jpeg, size, &w, &h, &subsampling, &colorspace) != 0) {
    rememberError(decompressor_);
    return endsWithEoi(jpeg, jpeg_bytes) ? Status::kCorruptData : Status::kTruncated;
  }
  if (w <= 0 || h <= 0) return endsWithEoi(jpeg, jpeg_bytes) ? Status::kCorruptData : Status::kTruncated;
  width = w;
  height = h;
  if (static_cast<uint64_t>(w) * static_cast<uint64_t>(h) > capacity_bytes) return Status::kCapacityExceeded;
  // Stop on the first warning: a damaged image is data to reject and count, not to use half-decoded.
  if (tjDecompress2(decompressor_, jpeg, size, out, w, 0, h, TJPF_GRAY, TJFLAG_STOPONWARNING) != 0) {
    rememberError(decompressor_);
    return endsWithEoi(jpeg, jpeg_bytes) ? Status::kCorruptData : Status::kTruncated;
  }
  return Status::kOk;
}

Status TurboJpegCodec::decodeGrayBinned(const uint8_t* jpeg, std::size_t jpeg_bytes, int32_t bin, uint8_t* out,
                                        std::size_t capacity_bytes, int32_t& width, int32_t& height) {
  width = 0;
  height = 0;
  if (jpeg == nullptr || out == nullptr || bin < 1 || bin > kMaxBinning) return Status::kInvalidArgument;
  if (bin == 1) return decodeGray(jpeg, jpeg_bytes, out, capacity_bytes, width, height);
  // The header first (a decode into no room fails on the size and reports it), then the binned size.
  uint8_t none = 0;
  Status s = decodeGray(jpeg, jpeg_bytes, &none, 0, width, height);
  if (s != Status::kCapacityExceeded || width <= 0 || height <= 0) return ok(s) ? Status::kCorruptData : s;
  LineBinner binner;
  if (!binner.begin(width, height, bin, out, capacity_bytes)) return Status::kCapacityExceeded;
  std::vector<uint8_t> full(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  s = decodeGray(jpeg, jpeg_bytes, full.data(), full.size(), width, height);
  if (!ok(s)) return s;
  for (int32_t y = 0; y < height; ++y) binner.addLine(full.data() + static_cast<std::size_t>(y) * width);
  return Status::kOk;
}

Status TurboJpegCodec::encodeGray(const uint8_t* pixels, int32_t width, int32_t height, int32_t quality,
                                  uint8_t* out, std::size_t capacity_bytes, std::size_t& encoded_bytes) {
  encoded_bytes = 0;
  last_error_[0] = '\0';
  if (pixels == nullptr || out == nullptr || width <= 0 || height <= 0 || quality < 1 || quality > 100) {
    return Status::kInvalidArgument;
  }
  if (compressor_ == nullptr) return Status::kUnsupported;
  if (capacity_bytes < maxEncodedBytes(width, height)) return Status::kCapacityExceeded;
  unsigned char* buffer = out;
  unsigned long size = static_cast<unsigned long>(capacity_bytes);
  if (tjCompress2(compressor_, pixels, width, 0, height, TJPF_GRAY, &buffer, &size, TJSAMP_GRAY, quality,
                  TJFLAG_NOREALLOC) != 0) {
    rememberError(compressor_);
    return Status::kIoError;
  }
  encoded_bytes = size;
  return Status::kOk;
}

std::size_t TurboJpegCodec::maxEncodedBytes(int32_t width, int32_t height) const {
  if (width <= 0 || height <= 0) return 0;
  return static_cast<std::size_t>(tjBufSize(width, height, TJSAMP_GRAY));
}

}  // namespace areomap::platform
