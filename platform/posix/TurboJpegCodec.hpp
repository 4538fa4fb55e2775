// JpegCodec on TurboJPEG. The TurboJPEG handles are created once by open() (they allocate) and reused.
// Note: libjpeg's memory manager still allocates its working pools inside every decode and frees them at
// the end of the call (tests/platform/JpegCodecTest.cpp measures how many); the pixels go straight into the
// caller's buffer.
#pragma once

#include "platform/JpegCodec.hpp"

namespace areomap::platform {

class TurboJpegCodec final : public JpegCodec {
 public:
  TurboJpegCodec() = default;
  ~TurboJpegCodec() override;
  TurboJpegCodec(const TurboJpegCodec&) = delete;
  TurboJpegCodec& operator=(const TurboJpegCodec&) = delete;

  // Creates the decompressor and compressor handles. kUnsupported if TurboJPEG cannot start.
  [[nodiscard]] Status open();

  [[nodiscard]] Status decodeGray(const uint8_t* jpeg, std::size_t jpeg_bytes, uint8_t* out,
                                  std::size_t capacity_bytes, int32_t& width, int32_t& height) override;
  // Decodes the whole frame into a temporary full-size buffer (heap), then bins it: the ground's and the
  // packer's codec; the rover's ArenaJpegDecoder bins line by line instead.
  [[nodiscard]] Status decodeGrayBinned(const uint8_t* jpeg, std::size_t jpeg_bytes, int32_t bin, uint8_t* out,
                                        std::size_t capacity_bytes, int32_t& width, int32_t& height) override;
  [[nodiscard]] Status encodeGray(const uint8_t* pixels, int32_t width, int32_t height, int32_t quality,
                                  uint8_t* out, std::size_t capacity_bytes,
                                  std::size_t& encoded_bytes) override;
  std::size_t maxEncodedBytes(int32_t width, int32_t height) const override;

  // TurboJPEG's message for the last failure ("" when none): for logs.
  const char* lastError() const { return last_error_; }

 private:
  void rememberError(void* handle);

  void* decompressor_ = nullptr;
  void* compressor_ = nullptr;
  char last_error_[200] = {0};
};

}  // namespace areomap::platform
