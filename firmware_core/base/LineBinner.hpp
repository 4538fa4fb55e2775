// Bins an 8-bit image b x b while its lines arrive one at a time (a JPEG decoder's scanlines): each output
// pixel is the rounded mean of one b x b block, floor(width / b) x floor(height / b) pixels row-major into
// the caller's buffer; the last width mod b columns and height mod b lines, which no whole block covers,
// are left out (the pixel frame of firmware_core/camera/Binning.hpp). The block sums live in a fixed array:
// no heap and no full-size buffer, whatever the source size.
#pragma once

#include <cstddef>
#include <cstdint>

#include "firmware_core/base/Capacities.hpp"

namespace areomap {

class LineBinner {
 public:
  // Prepares a width x height source binned by b into `out` (capacity bytes). False (nothing prepared)
  // when b is outside 1..kMaxBinning, a side is not positive, the binned width exceeds kMaxImageWidth or
  // the binned image exceeds `capacity`.
  bool begin(int32_t width, int32_t height, int32_t b, uint8_t* out, std::size_t capacity) {
    width_ = 0;
    if (out == nullptr || b < 1 || b > kMaxBinning || width <= 0 || height <= 0) return false;
    const int32_t bw = width / b, bh = height / b;
    if (bw < 1 || bh < 1 || bw > kMaxImageWidth) return false;
    if (static_cast<std::size_t>(bw) * static_cast<std::size_t>(bh) > capacity) return false;
    width_ = width;
    b_ = b;
    binned_width_ = bw;
    binned_height_ = bh;
    out_ = out;
    line_ = 0;
    for (int32_t i = 0; i < bw; ++i) sums_[i] = 0;
    return true;
  }

  // The next source line (width pixels). Lines past the last whole block row are ignored.
  void addLine(const uint8_t* pixels) {
    const int32_t row = line_ / b_;
    line_ += 1;
    if (width_ == 0 || row >= binned_height_) return;
    for (int32_t x = 0; x < binned_width_; ++x) {
      uint32_t s = 0;
      const uint8_t* p = pixels + static_cast<std::size_t>(x) * static_cast<std::size_t>(b_);
      for (int32_t k = 0; k < b_; ++k) s += p[k];
      sums_[x] += s;
    }
    if (line_ % b_ != 0) return;
    const uint32_t n = static_cast<uint32_t>(b_) * static_cast<uint32_t>(b_);
    uint8_t* out = out_ + static_cast<std::size_t>(row) * static_cast<std::size_t>(binned_width_);
    for (int32_t x = 0; x < binned_width_; ++x) {
      out[x] = static_cast<uint8_t>((sums_[x] + n / 2) / n);
      sums_[x] = 0;
    }
  }

  int32_t binnedWidth() const { return binned_width_; }
  int32_t binnedHeight() const { return binned_height_; }

 private:
  uint32_t sums_[kMaxImageWidth] = {};
  uint8_t* out_ = nullptr;
  int32_t width_ = 0;
  int32_t b_ = 1;
  int32_t binned_width_ = 0;
  int32_t binned_height_ = 0;
  int32_t line_ = 0;
};

}  // namespace areomap
