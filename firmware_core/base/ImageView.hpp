// A read-only view of an 8-bit image owned by someone else (a decode buffer, a test array). No ownership,
// no heap. Pixel (x, y) = sample x, line y, at pixels[y * stride + x].
#pragma once

#include <cstdint>

namespace areomap {

struct ImageView {
  const uint8_t* pixels = nullptr;
  int32_t width = 0;
  int32_t height = 0;
  int32_t stride = 0;  // bytes from one line to the next (>= width)

  bool valid() const { return pixels != nullptr && width > 0 && height > 0 && stride >= width; }
  uint8_t at(int32_t x, int32_t y) const { return pixels[y * stride + x]; }
  const uint8_t* row(int32_t y) const { return pixels + y * stride; }
};

}  // namespace areomap
