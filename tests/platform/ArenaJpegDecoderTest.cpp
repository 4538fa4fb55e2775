// ArenaJpegDecoder: the rover's heap-free JPEG decode (libjpeg with its memory manager on a static arena).
#include <cmath>
#include <cstdio>
#include <cstring>
#include <thread>
#include <vector>

#include "firmware_core/base/Capacities.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "platform/posix/ArenaJpegDecoder.hpp"
#include "platform/posix/TurboJpegCodec.hpp"

#include <turbojpeg.h>

#include <CppUTest/TestHarness.h>

using areomap::Status;
using areomap::platform::ArenaJpegDecoder;
using areomap::platform::TurboJpegCodec;

namespace {

int code(Status s) { return static_cast<int>(s); }

uint8_t g_arena[ArenaJpegDecoder::kArenaBytes];
uint8_t g_out[areomap::kMaxImagePixels];

std::vector<uint8_t> makeJpeg(int width, int height, int quality, std::vector<uint8_t>* reference) {
  std::vector<uint8_t> pixels(static_cast<std::size_t>(width) * height);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double v = 128.0 + 60.0 * std::sin(x * 0.029) * std::cos(y * 0.019) + 25.0 * std::sin((x + 3 * y) * 0.23);
      pixels[static_cast<std::size_t>(y) * width + x] = static_cast<uint8_t>(std::lround(v));
    }
  }
  TurboJpegCodec codec;
  CHECK(ok(codec.open()));
  std::vector<uint8_t> jpeg(codec.maxEncodedBytes(width, height));
  std::size_t bytes = 0;
  CHECK(ok(codec.encodeGray(pixels.data(), width, height, quality, jpeg.data(), jpeg.size(), bytes)));
  jpeg.resize(bytes);
  if (reference != nullptr) {
    // The independent decode: TurboJPEG's own (same library, its own memory manager).
    reference->assign(pixels.size(), 0);
    int32_t w = 0, h = 0;
    CHECK(ok(codec.decodeGray(jpeg.data(), jpeg.size(), reference->data(), reference->size(), w, h)));
  }
  return jpeg;
}

}  // namespace

TEST_GROUP(ArenaJpegDecoder){};

// Pixels identical to TurboJPEG's decode, for several sizes, and no heap allocation after open().
TEST(ArenaJpegDecoder, DecodesLikeTurboJpegWithoutHeap) {
  ArenaJpegDecoder decoder(g_arena, sizeof(g_arena));
  CHECK_EQUAL(code(Status::kOk), code(decoder.open()));
  const int sizes[][2] = {{1024, 1024}, {640, 480}, {33, 17}};
  for (const auto& s : sizes) {
    std::vector<uint8_t> reference;
    const std::vector<uint8_t> jpeg = makeJpeg(s[0], s[1], 95, &reference);
    int32_t w = 0, h = 0;
    // First decode of a size may take the permanent tables from the arena: warm-up, then count.
    CHECK_EQUAL(code(Status::kOk), code(decoder.decodeGray(jpeg.data(), jpeg.size(), g_out, sizeof(g_out), w, h)));
    areomap::HeapAllocationScope scope;
    for (int k = 0; k < 5; ++k) {
      std::memset(g_out, 0, sizeof(g_out));
      CHECK_EQUAL(code(Status::kOk), code(decoder.decodeGray(jpeg.data(), jpeg.size(), g_out, sizeof(g_out), w, h)));
    }
    CHECK_EQUAL(0u, scope.allocations());
    CHECK_EQUAL(s[0], w);
    CHECK_EQUAL(s[1], h);
    CHECK_EQUAL(0, std::memcmp(reference.data(), g_out, reference.size()));
  }
  std::printf("arena JPEG decoder: high water %zu bytes of %zu\n", decoder.arenaHighWater(), sizeof(g_arena));
  CHECK(decoder.arenaHighWater() < sizeof(g_arena) / 2);
}

// Binned while decoding: frames above the capacity (up to kMaxBinning times it) decode into the
// capacity-sized buffer as the b x b block means of TurboJPEG's full decode (computed here directly), with
// no heap; TurboJpegCodec's binned decode (the ground's) gives the same pixels. A binned image larger than
// the buffer, or a factor outside 1..kMaxBinning, is refused before decoding.
TEST(ArenaJpegDecoder, BinsWhileDecodingWithoutHeap) {
  ArenaJpegDecoder decoder(g_arena, sizeof(g_arena));
  CHECK_EQUAL(code(Status::kOk), code(decoder.open()));
  TurboJpegCodec turbo;
  CHECK(ok(turbo.open()));
  const int cases[][3] = {{2050, 1537, 3}, {1288, 968, 2}, {5120, 64, 5}, {8199, 40, 8}};
  std::vector<uint8_t> turbo_out(sizeof(g_out));
  for (const auto& c : cases) {
    const int width = c[0], height = c[1], b = c[2];
    std::vector<uint8_t> full;
    const std::vector<uint8_t> jpeg = makeJpeg(width, height, 90, &full);
    int32_t w = 0, h = 0;
    CHECK_EQUAL(code(Status::kOk),
                code(decoder.decodeGrayBinned(jpeg.data(), jpeg.size(), b, g_out, sizeof(g_out), w, h)));
    areomap::HeapAllocationScope scope;
    CHECK_EQUAL(code(Status::kOk),
                code(decoder.decodeGrayBinned(jpeg.data(), jpeg.size(), b, g_out, sizeof(g_out), w, h)));
    CHECK_EQUAL(0u, scope.allocations());
    CHECK_EQUAL(width, w);
    CHECK_EQUAL(height, h);
    const int bw = width / b, bh = height / b;
    int wrong = 0;
    for (int yb = 0; yb < bh; ++yb) {
      for (int xb = 0; xb < bw; ++xb) {
        int sum = 0;
        for (int dy = 0; dy < b; ++dy)
          for (int dx = 0; dx < b; ++dx) sum += full[static_cast<std::size_t>(yb * b + dy) * width + xb * b + dx];
        const int expected = (2 * sum + b * b) / (2 * b * b);
        wrong += g_out[static_cast<std::size_t>(yb) * bw + xb] != expected ? 1 : 0;
      }
    }
    CHECK_EQUAL(0, wrong);
    CHECK_EQUAL(code(Status::kOk), code(turbo.decodeGrayBinned(jpeg.data(), jpeg.size(), b, turbo_out.data(),
                                                                turbo_out.size(), w, h)));
    CHECK_EQUAL(0, std::memcmp(turbo_out.data(), g_out, static_cast<std::size_t>(bw) * bh));
  }
  const std::vector<uint8_t> jpeg = makeJpeg(2050, 40, 90, nullptr);
  int32_t w = 0, h = 0;
  CHECK_EQUAL(code(Status::kCapacityExceeded), code(decoder.decodeGrayBinned(jpeg.data(), jpeg.size(), 2, g_out,
                                                                             sizeof(g_out), w, h)));  // 1025 wide
  CHECK_EQUAL(2050, w);
  CHECK_EQUAL(code(Status::kCapacityExceeded),
              code(decoder.decodeGrayBinned(jpeg.data(), jpeg.size(), 3, g_out, 100, w, h)));
  CHECK_EQUAL(code(Status::kInvalidArgument),
              code(decoder.decodeGrayBinned(jpeg.data(), jpeg.size(), 0, g_out, sizeof(g_out), w, h)));
  CHECK_EQUAL(code(Status::kInvalidArgument), code(decoder.decodeGrayBinned(jpeg.data(), jpeg.size(), areomap::kMaxBinning + 1,
                                                                            g_out, sizeof(g_out), w, h)));
  // The decoder goes on: the next decode works.
  CHECK_EQUAL(code(Status::kOk),
              code(decoder.decodeGrayBinned(jpeg.data(), jpeg.size(), 3, g_out, sizeof(g_out), w, h)));
}

// A second thread that decodes makes no heap allocation after its warm-up: libjpeg-turbo detects its SIMD
// support once per thread (thread-local), and on 64-bit ARM that detection mallocs and reads /proc/cpuinfo
// (the 3 allocations the rover's pipeline thread made under qemu-aarch64). Natively this holds without
// the warm-up too; under qemu-aarch64 (ctest --preset aarch64) it fails without it.
TEST(ArenaJpegDecoder, AnotherThreadDecodesWithoutHeapAfterItsWarmUp) {
  ArenaJpegDecoder decoder(g_arena, sizeof(g_arena));
  CHECK_EQUAL(code(Status::kOk), code(decoder.open()));
  std::vector<uint8_t> reference;
  const std::vector<uint8_t> jpeg = makeJpeg(96, 64, 90, &reference);
  Status warm = Status::kUnsupported;
  Status decoded = Status::kUnsupported;
  uint64_t allocations = 1;
  std::thread pipeline([&] {
    warm = decoder.warmUpThisThread();
    const uint64_t mark = areomap::heapAllocationCountThisThread();
    int32_t w = 0, h = 0;
    decoded = decoder.decodeGray(jpeg.data(), jpeg.size(), g_out, sizeof(g_out), w, h);
    allocations = areomap::heapAllocationCountThisThread() - mark;
  });
  pipeline.join();
  CHECK_EQUAL(code(Status::kOk), code(warm));
  CHECK_EQUAL(code(Status::kOk), code(decoded));
  CHECK_EQUAL(0u, allocations);
  CHECK_EQUAL(0, std::memcmp(reference.data(), g_out, reference.size()));
}

// Bad input gives its status, with no heap, and the decoder keeps working afterwards.
TEST(ArenaJpegDecoder, BadInputHasAStatusAndTheNextDecodeWorks) {
  ArenaJpegDecoder decoder(g_arena, sizeof(g_arena));
  CHECK_EQUAL(code(Status::kOk), code(decoder.open()));
  std::vector<uint8_t> reference;
  const std::vector<uint8_t> jpeg = makeJpeg(512, 256, 90, &reference);
  int32_t w = 0, h = 0;
  CHECK_EQUAL(code(Status::kOk), code(decoder.decodeGray(jpeg.data(), jpeg.size(), g_out, sizeof(g_out), w, h)));
  std::vector<uint8_t> bad = jpeg;  // a damaged frame header: sample precision 3
  for (std::size_t b = 2; b + 8 < bad.size(); ++b) {
    if (bad[b] == 0xFF && bad[b + 1] == 0xC0) {
      bad[b + 4] = 3;
      break;
    }
  }
  areomap::HeapAllocationScope scope;
  // Truncated in the entropy-coded data.
  CHECK_EQUAL(code(Status::kTruncated), code(decoder.decodeGray(jpeg.data(), jpeg.size() / 2, g_out, sizeof(g_out), w, h)));
  // Not a JPEG.
  const uint8_t garbage[64] = {1, 2, 3, 4, 5};
  CHECK_EQUAL(code(Status::kCorruptData), code(decoder.decodeGray(garbage, sizeof(garbage), g_out, sizeof(g_out), w, h)));
  // The damaged frame header.
  CHECK_EQUAL(code(Status::kCorruptData), code(decoder.decodeGray(bad.data(), bad.size(), g_out, sizeof(g_out), w, h)));
  // Larger than the output buffer: refused before decoding, the size reported.
  CHECK_EQUAL(code(Status::kCapacityExceeded), code(decoder.decodeGray(jpeg.data(), jpeg.size(), g_out, 1000, w, h)));
  CHECK_EQUAL(512, w);
  CHECK_EQUAL(256, h);
  CHECK_EQUAL(code(Status::kInvalidArgument), code(decoder.decodeGray(nullptr, 10, g_out, sizeof(g_out), w, h)));
  // And a good one again, pixel-exact.
  CHECK_EQUAL(code(Status::kOk), code(decoder.decodeGray(jpeg.data(), jpeg.size(), g_out, sizeof(g_out), w, h)));
  CHECK_EQUAL(0, std::memcmp(reference.data(), g_out, reference.size()));
  CHECK_EQUAL(0u, scope.allocations());
}

// An arena too small for the working memory of a wide image: kCapacityExceeded, no crash, no heap.
TEST(ArenaJpegDecoder, ArenaTooSmallIsCapacityExceeded) {
  static uint8_t small_arena[80 * 1024];  // ~78 KiB usable; a 16384-px-wide decode needs ~0.25 MiB
  ArenaJpegDecoder decoder(small_arena, sizeof(small_arena));
  CHECK_EQUAL(code(Status::kOk), code(decoder.open()));
  const std::vector<uint8_t> jpeg = makeJpeg(16384, 16, 90, nullptr);
  int32_t w = 0, h = 0;
  areomap::HeapAllocationScope scope;
  CHECK_EQUAL(code(Status::kCapacityExceeded),
              code(decoder.decodeGray(jpeg.data(), jpeg.size(), g_out, sizeof(g_out), w, h)));
  CHECK_EQUAL(0u, scope.allocations());
}

// Found by fuzz_jpeg (tests/fuzz/regressions/jpeg/multiscan_coefficient_buffer_leaked_per_decode): a
// progressive (multi-scan) JPEG needs libjpeg's whole-image coefficient buffer, which its memory manager
// allocates past the arena methods (malloc). It used to stay allocated after every such decode (RSS past
// 2.5 GB in 680 000 fuzz runs); now all of it is freed when the decode ends, and the pixels are right.
TEST(ArenaJpegDecoder, HeapThatLibjpegTakesPastTheArenaIsFreedAfterEveryDecode) {
  if (!areomap::heapCounterActive()) {
    std::printf("SKIP: the heap counter is compiled out in this build (sanitizers)\n");
    return;
  }
  std::vector<uint8_t> reference;
  (void)makeJpeg(256, 128, 90, &reference);  // the pixels, decoded from a baseline JPEG of the same image
  std::vector<uint8_t> pixels(256 * 128);
  for (int y = 0; y < 128; ++y) {
    for (int x = 0; x < 256; ++x) {
      const double v = 128.0 + 60.0 * std::sin(x * 0.029) * std::cos(y * 0.019) + 25.0 * std::sin((x + 3 * y) * 0.23);
      pixels[static_cast<std::size_t>(y) * 256 + x] = static_cast<uint8_t>(std::lround(v));
    }
  }
  tjhandle compressor = tjInitCompress();
  unsigned char* progressive = nullptr;
  unsigned long bytes = 0;
  CHECK_EQUAL(0, tjCompress2(compressor, pixels.data(), 256, 0, 128, TJPF_GRAY, &progressive, &bytes, TJSAMP_GRAY, 90,
                             TJFLAG_PROGRESSIVE));
  ArenaJpegDecoder decoder(g_arena, sizeof(g_arena));
  CHECK_EQUAL(code(Status::kOk), code(decoder.open()));
  const uint64_t allocations = areomap::heapAllocationCount(), frees = areomap::heapFreeCount();
  for (int k = 0; k < 20; ++k) {
    int32_t w = 0, h = 0;
    CHECK_EQUAL(code(Status::kOk), code(decoder.decodeGray(progressive, bytes, g_out, sizeof(g_out), w, h)));
  }
  const uint64_t allocated = areomap::heapAllocationCount() - allocations, freed = areomap::heapFreeCount() - frees;
  tjFree(progressive);
  tjDestroy(compressor);
  CHECK(allocated >= 20);  // a progressive decode does take heap (libjpeg's own allocation), and
  CHECK_EQUAL(allocated, freed);  // gives all of it back
  CHECK_EQUAL(0, std::memcmp(reference.data(), g_out, reference.size()));  // same pixels as baseline
}
