// Fuzz target: JPEG decoding into the rover's fixed buffers, by both codecs of platform/posix:
// ArenaJpegDecoder (libjpeg on a static arena, the rover's) and TurboJpegCodec (the ground's and the
// pack's). Capacity = kMaxImagePixels, as RoverNode::decodeSide passes it.
// Invariants: a decode that says kOk reports a size within the capacity; when both codecs accept the same
// bytes they produce the same size and the same pixels (both are libjpeg-turbo with islow IDCT, gray out).
#include <cstring>

#include "firmware_core/base/Capacities.hpp"
#include "platform/posix/ArenaJpegDecoder.hpp"
#include "platform/posix/TurboJpegCodec.hpp"
#include "tests/fuzz/FuzzSupport.hpp"

namespace {

using areomap::Status;
using areomap::fuzz::fail;

constexpr std::size_t kCapacity = static_cast<std::size_t>(areomap::kMaxImagePixels);
uint8_t g_arena[areomap::platform::ArenaJpegDecoder::kArenaBytes];
uint8_t g_arena_pixels[kCapacity];
uint8_t g_turbo_pixels[kCapacity];

void checkSize(Status s, int32_t width, int32_t height, const char* which) {
  if (!areomap::ok(s)) return;
  if (width <= 0 || height <= 0 ||
      static_cast<std::size_t>(width) * static_cast<std::size_t>(height) > kCapacity) {
    fail("jpeg", which);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  static areomap::platform::ArenaJpegDecoder arena(g_arena, sizeof g_arena);
  static areomap::platform::TurboJpegCodec turbo;
  static const bool opened = areomap::ok(arena.open()) && areomap::ok(turbo.open());
  if (!opened) fail("jpeg", "a codec does not open");

  int32_t aw = 0, ah = 0, tw = 0, th = 0;
  const Status sa = arena.decodeGray(data, size, g_arena_pixels, kCapacity, aw, ah);
  checkSize(sa, aw, ah, "ArenaJpegDecoder: kOk with a size beyond the capacity");
  const Status st = turbo.decodeGray(data, size, g_turbo_pixels, kCapacity, tw, th);
  checkSize(st, tw, th, "TurboJpegCodec: kOk with a size beyond the capacity");
  if (areomap::ok(sa) && areomap::ok(st)) {
    if (aw != tw || ah != th) fail("jpeg", "the two codecs decode different sizes");
    const std::size_t n = static_cast<std::size_t>(aw) * static_cast<std::size_t>(ah);
    if (std::memcmp(g_arena_pixels, g_turbo_pixels, n) != 0) fail("jpeg", "the two codecs decode different pixels");
  }
  return 0;
}
