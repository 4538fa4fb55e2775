// JPEG decoding with zero heap after open(): the libjpeg API of libjpeg-turbo with the decompressor's
// memory manager methods (alloc_small, alloc_large, alloc_sarray, alloc_barray, free_pool) replaced by a
// bump allocator over a caller-provided arena. open() creates the decompressor (libjpeg allocates its
// permanent pool then, once); every decode takes its working memory (Huffman tables, IDCT and colour
// buffers: ~100 KiB for a 1024-px wide gray image) from the arena and releases it all at the end.
// Pixels go straight into the caller's buffer. 8-bit gray/colour JPEGs decode to gray; a JPEG that needs
// more working memory than the arena is refused with kCapacityExceeded. Heap-free for sequential (baseline)
// JPEGs, which is what areomap-pack writes: a progressive JPEG's whole-image coefficient buffer is made by
// libjpeg's internal virtual-array code, which still calls malloc.
// Encoding is not offered (the rover does not encode): encodeGray returns kUnsupported.
#pragma once

#include "platform/JpegCodec.hpp"

namespace areomap::platform {

class ArenaJpegDecoder final : public JpegCodec {
 public:
  // Arena for one decoder: a baseline 1024-px-wide gray decode needs ~17 KiB (measured, ArenaJpegDecoderTest);
  // 1 MiB leaves room for 16-bit-wide tables, restart markers and images up to ~60000 px wide.
  static constexpr std::size_t kArenaBytes = 1024u * 1024u;

  ArenaJpegDecoder(uint8_t* arena, std::size_t arena_bytes) : arena_(arena), arena_bytes_(arena_bytes) {}
  ~ArenaJpegDecoder() override;
  ArenaJpegDecoder(const ArenaJpegDecoder&) = delete;
  ArenaJpegDecoder& operator=(const ArenaJpegDecoder&) = delete;

  // Creates the decompressor (heap, once) and warms the calling thread up. kUnsupported when libjpeg
  // cannot start.
  [[nodiscard]] Status open();
  // Decodes a built-in 16x16 JPEG: libjpeg-turbo's per-thread SIMD detection (heap on 64-bit ARM, see the
  // .cpp) happens now. Every thread that decodes calls it once at its start-up, before its heap mark;
  // open() does it for the calling thread.
  [[nodiscard]] Status warmUpThisThread();

  [[nodiscard]] Status decodeGray(const uint8_t* jpeg, std::size_t jpeg_bytes, uint8_t* out,
                                  std::size_t capacity_bytes, int32_t& width, int32_t& height) override;
  // Binned line by line: each decoded line goes into one line of the arena and into the block sums (the
  // decoder's state in the arena), never a full-size buffer.
  [[nodiscard]] Status decodeGrayBinned(const uint8_t* jpeg, std::size_t jpeg_bytes, int32_t bin, uint8_t* out,
                                        std::size_t capacity_bytes, int32_t& width, int32_t& height) override;
  [[nodiscard]] Status encodeGray(const uint8_t* pixels, int32_t width, int32_t height, int32_t quality,
                                  uint8_t* out, std::size_t capacity_bytes, std::size_t& encoded_bytes) override;
  std::size_t maxEncodedBytes(int32_t width, int32_t height) const override;

  std::size_t arenaHighWater() const { return high_water_; }
  const char* lastError() const { return last_error_; }

  // Internal state reached from libjpeg's callbacks.
  struct State;

 private:
  uint8_t* arena_;
  std::size_t arena_bytes_;
  std::size_t high_water_ = 0;
  State* state_ = nullptr;
  char last_error_[200] = {0};
};

}  // namespace areomap::platform
