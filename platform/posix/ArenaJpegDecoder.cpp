#include "platform/posix/ArenaJpegDecoder.hpp"

#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <new>

#include <jpeglib.h>
// jerror.h after jpeglib.h: message codes and ERREXIT.
#include <jerror.h>

#include "firmware_core/base/LineBinner.hpp"

namespace areomap::platform {

// Lives in the arena's first bytes: no heap for the decoder's own state either.
struct ArenaJpegDecoder::State {
  jpeg_decompress_struct cinfo;
  jpeg_error_mgr error;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
  bool truncated;
  // Arena for JPOOL_IMAGE (and any JPOOL_PERMANENT request after open()).
  uint8_t* base;
  std::size_t capacity;
  std::size_t used;       // JPOOL_IMAGE, from the start; reset after every image
  std::size_t permanent;  // JPOOL_PERMANENT (quantisation and Huffman tables made on the first image), from
                          // the end; kept for the decoder's life
  std::size_t high_water;
  bool exhausted;
  LineBinner binner;  // decodeGrayBinned's block sums
  // libjpeg's own methods, kept for self_destruct.
  void (*original_free_pool)(j_common_ptr, int);
};

namespace {

using State = ArenaJpegDecoder::State;

State* stateOf(j_common_ptr cinfo) { return reinterpret_cast<State*>(cinfo->client_data); }

void* arenaAlloc(j_common_ptr cinfo, int pool_id, size_t bytes) {
  State* s = stateOf(cinfo);
  const std::size_t aligned = (bytes + 15u) & ~std::size_t{15};
  if (aligned > s->capacity - s->used - s->permanent) {
    s->exhausted = true;
    ERREXIT1(cinfo, JERR_OUT_OF_MEMORY, 77);
  }
  void* p = nullptr;
  if (pool_id == JPOOL_PERMANENT) {
    s->permanent += aligned;
    p = s->base + s->capacity - s->permanent;
  } else {
    p = s->base + s->used;
    s->used += aligned;
  }
  if (s->used + s->permanent > s->high_water) s->high_water = s->used + s->permanent;
  return p;
}

JSAMPARRAY arenaSarray(j_common_ptr cinfo, int pool_id, JDIMENSION samplesperrow, JDIMENSION numrows) {
  auto rows = static_cast<JSAMPARRAY>(arenaAlloc(cinfo, pool_id, numrows * sizeof(JSAMPROW)));
  auto data = static_cast<JSAMPLE*>(arenaAlloc(cinfo, pool_id, static_cast<size_t>(numrows) * samplesperrow));
  for (JDIMENSION r = 0; r < numrows; ++r) rows[r] = data + static_cast<size_t>(r) * samplesperrow;
  return rows;
}

JBLOCKARRAY arenaBarray(j_common_ptr cinfo, int pool_id, JDIMENSION blocksperrow, JDIMENSION numrows) {
  auto rows = static_cast<JBLOCKARRAY>(arenaAlloc(cinfo, pool_id, numrows * sizeof(JBLOCKROW)));
  auto data = static_cast<JBLOCKROW>(arenaAlloc(cinfo, pool_id, static_cast<size_t>(numrows) * blocksperrow * sizeof(JBLOCK)));
  for (JDIMENSION r = 0; r < numrows; ++r) rows[r] = data + static_cast<size_t>(r) * blocksperrow;
  return rows;
}

void arenaFreePool(j_common_ptr cinfo, int pool_id) {
  State* s = stateOf(cinfo);
  if (pool_id != JPOOL_IMAGE) return;  // JPOOL_PERMANENT: freed by self_destruct (jpeg_destroy)
  s->used = 0;
  // libjpeg's own image pool: what its memory manager allocated past our methods (the virtual arrays of a
  // progressive or multi-scan JPEG: realize_virt_arrays calls its internal alloc_barray, i.e. malloc). Its
  // lists never hold arena blocks, and they are empty for a baseline JPEG (no heap call then). Without
  // this every such decode leaked its coefficient buffer (fuzz_jpeg: RSS past 2.5 GB after 680 000 runs).
  s->original_free_pool(cinfo, JPOOL_IMAGE);
}

void onError(j_common_ptr cinfo) {
  State* s = stateOf(cinfo);
  (*cinfo->err->format_message)(cinfo, s->message);
  std::longjmp(s->jump, 1);
}

void onMessage(j_common_ptr cinfo, int level) {
  // Warnings (level -1): a premature end of data is a truncated file.
  if (level < 0 && cinfo->err->msg_code == JWRN_JPEG_EOF) stateOf(cinfo)->truncated = true;
}

}  // namespace

ArenaJpegDecoder::~ArenaJpegDecoder() {
  if (state_ != nullptr) {
    state_->cinfo.mem->free_pool = state_->original_free_pool;
    jpeg_destroy_decompress(&state_->cinfo);
    state_->~State();
  }
}

// A 16x16 gray baseline JPEG (quality 50, made with TurboJPEG) for warmUpThisThread(). libjpeg-turbo
// detects its SIMD support lazily, on a thread's first decode, and keeps the result in thread-local storage
// (`static THREAD_LOCAL unsigned int simd_support` in simd/arm/aarch64/jsimd.c of 2.1.x): on 64-bit ARM
// that detection reads /proc/cpuinfo with malloc(1024), fopen and fgets's stdio buffer (3 heap
// allocations, found with AREOMAP_HEAP_TRACE=1 under qemu-aarch64: parse_proc_cpuinfo <- init_simd <-
// jsimd_can_* <- jinit_color_deconverter <- jpeg_start_decompress). On x86-64 it is cpuid, no heap.
constexpr uint8_t kWarmUpJpeg[] = {
    0xFF, 0xD8, 0xFF, 0xE0, 0x00, 0x10, 0x4A, 0x46, 0x49, 0x46, 0x00, 0x01, 0x01, 0x00, 0x00, 0x01,
    0x00, 0x01, 0x00, 0x00, 0xFF, 0xDB, 0x00, 0x43, 0x00, 0x10, 0x0B, 0x0C, 0x0E, 0x0C, 0x0A, 0x10,
    0x0E, 0x0D, 0x0E, 0x12, 0x11, 0x10, 0x13, 0x18, 0x28, 0x1A, 0x18, 0x16, 0x16, 0x18, 0x31, 0x23,
    0x25, 0x1D, 0x28, 0x3A, 0x33, 0x3D, 0x3C, 0x39, 0x33, 0x38, 0x37, 0x40, 0x48, 0x5C, 0x4E, 0x40,
    0x44, 0x57, 0x45, 0x37, 0x38, 0x50, 0x6D, 0x51, 0x57, 0x5F, 0x62, 0x67, 0x68, 0x67, 0x3E, 0x4D,
    0x71, 0x79, 0x70, 0x64, 0x78, 0x5C, 0x65, 0x67, 0x63, 0xFF, 0xC0, 0x00, 0x0B, 0x08, 0x00, 0x10,
    0x00, 0x10, 0x01, 0x01, 0x11, 0x00, 0xFF, 0xC4, 0x00, 0x1F, 0x00, 0x00, 0x01, 0x05, 0x01, 0x01,
    0x01, 0x01, 0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01, 0x02, 0x03, 0x04,
    0x05, 0x06, 0x07, 0x08, 0x09, 0x0A, 0x0B, 0xFF, 0xC4, 0x00, 0xB5, 0x10, 0x00, 0x02, 0x01, 0x03,
    0x03, 0x02, 0x04, 0x03, 0x05, 0x05, 0x04, 0x04, 0x00, 0x00, 0x01, 0x7D, 0x01, 0x02, 0x03, 0x00,
    0x04, 0x11, 0x05, 0x12, 0x21, 0x31, 0x41, 0x06, 0x13, 0x51, 0x61, 0x07, 0x22, 0x71, 0x14, 0x32,
    0x81, 0x91, 0xA1, 0x08, 0x23, 0x42, 0xB1, 0xC1, 0x15, 0x52, 0xD1, 0xF0, 0x24, 0x33, 0x62, 0x72,
    0x82, 0x09, 0x0A, 0x16, 0x17, 0x18, 0x19, 0x1A, 0x25, 0x26, 0x27, 0x28, 0x29, 0x2A, 0x34, 0x35,
    0x36, 0x37, 0x38, 0x39, 0x3A, 0x43, 0x44, 0x45, 0x46, 0x47, 0x48, 0x49, 0x4A, 0x53, 0x54, 0x55,
    0x56, 0x57, 0x58, 0x59, 0x5A, 0x63, 0x64, 0x65, 0x66, 0x67, 0x68, 0x69, 0x6A, 0x73, 0x74, 0x75,
    0x76, 0x77, 0x78, 0x79, 0x7A, 0x83, 0x84, 0x85, 0x86, 0x87, 0x88, 0x89, 0x8A, 0x92, 0x93, 0x94,
    0x95, 0x96, 0x97, 0x98, 0x99, 0x9A, 0xA2, 0xA3, 0xA4, 0xA5, 0xA6, 0xA7, 0xA8, 0xA9, 0xAA, 0xB2,
    0xB3, 0xB4, 0xB5, 0xB6, 0xB7, 0xB8, 0xB9, 0xBA, 0xC2, 0xC3, 0xC4, 0xC5, 0xC6, 0xC7, 0xC8, 0xC9,
    0xCA, 0xD2, 0xD3, 0xD4, 0xD5, 0xD6, 0xD7, 0xD8, 0xD9, 0xDA, 0xE1, 0xE2, 0xE3, 0xE4, 0xE5, 0xE6,
    0xE7, 0xE8, 0xE9, 0xEA, 0xF1, 0xF2, 0xF3, 0xF4, 0xF5, 0xF6, 0xF7, 0xF8, 0xF9, 0xFA, 0xFF, 0xDA,
    0x00, 0x08, 0x01, 0x01, 0x00, 0x00, 0x3F, 0x00, 0x48, 0xE3, 0x83, 0xEC, 0xEC, 0x13, 0x68, 0xB7,
    0x04, 0xAB, 0x47, 0x09, 0xF2, 0xA3, 0x03, 0x38, 0xF9, 0xE5, 0x3F, 0x7B, 0x21, 0xB1, 0xC6, 0x54,
    0xE0, 0x70, 0x29, 0xA3, 0xCB, 0x7B, 0x42, 0xD2, 0x2F, 0xEE, 0x06, 0x02, 0x82, 0xA6, 0x18, 0x09,
    0xDB, 0x9E, 0x9F, 0x7D, 0xCE, 0x57, 0x3B, 0x4F, 0x3D, 0x71, 0x8A, 0x91, 0xBC, 0xC0, 0xE8, 0xF3,
    0xAE, 0x1B, 0x61, 0xF2, 0xC4, 0xEA, 0x1A, 0x5E, 0x57, 0x82, 0x91, 0xAF, 0xCA, 0x9C, 0xA9, 0xE4,
    0xE4, 0x12, 0x06, 0x69, 0xC5, 0x65, 0x17, 0x81, 0xDC, 0xB2, 0xCC, 0x0F, 0x09, 0xB4, 0x4D, 0x39,
    0x19, 0xCE, 0x30, 0x7E, 0x54, 0x18, 0x60, 0x76, 0xF1, 0xDF, 0x04, 0xD7, 0xFF, 0xD9};

Status ArenaJpegDecoder::warmUpThisThread() {
  uint8_t pixels[16 * 16];
  int32_t width = 0, height = 0;
  const Status warm = decodeGray(kWarmUpJpeg, sizeof(kWarmUpJpeg), pixels, sizeof(pixels), width, height);
  if (ok(warm) && (width != 16 || height != 16)) return Status::kCorruptData;
  return warm;
}

Status ArenaJpegDecoder::open() {
  if (state_ != nullptr) return Status::kOk;
  if (arena_ == nullptr || arena_bytes_ < sizeof(State) + 64 * 1024) return Status::kInvalidArgument;
  State* s = new (arena_) State();
  const std::size_t offset = (sizeof(State) + 63u) & ~std::size_t{63};
  s->base = arena_ + offset;
  s->capacity = arena_bytes_ - offset;
  s->cinfo.err = jpeg_std_error(&s->error);
  s->error.error_exit = onError;
  s->error.emit_message = onMessage;
  s->cinfo.client_data = s;
  if (setjmp(s->jump) != 0) {
    std::snprintf(last_error_, sizeof(last_error_), "%s", s->message);
    s->~State();
    return Status::kUnsupported;
  }
  jpeg_create_decompress(&s->cinfo);
  // The memory source manager is made once (libjpeg's permanent pool) and reused by every decode.
  static const uint8_t kNoData[2] = {0xFF, 0xD8};
  jpeg_mem_src(&s->cinfo, kNoData, sizeof(kNoData));
  s->original_free_pool = s->cinfo.mem->free_pool;
  s->cinfo.mem->alloc_small = arenaAlloc;
  s->cinfo.mem->alloc_large = arenaAlloc;
  s->cinfo.mem->alloc_sarray = arenaSarray;
  s->cinfo.mem->alloc_barray = arenaBarray;
  s->cinfo.mem->free_pool = arenaFreePool;
  state_ = s;
  const Status warm = warmUpThisThread();
  if (!ok(warm)) {
    std::snprintf(last_error_, sizeof(last_error_), "the start-up decode failed: %s", statusName(warm));
    return Status::kUnsupported;
  }
  return Status::kOk;
}

Status ArenaJpegDecoder::decodeGray(const uint8_t* jpeg, std::size_t jpeg_bytes, uint8_t* out,
                                    std::size_t capacity_bytes, int32_t& width, int32_t& height) {
  return decodeGrayBinned(jpeg, jpeg_bytes, 1, out, capacity_bytes, width, height);
}

Status ArenaJpegDecoder::decodeGrayBinned(const uint8_t* jpeg, std::size_t jpeg_bytes, int32_t bin, uint8_t* out,
                                          std::size_t capacity_bytes, int32_t& width, int32_t& height) {
  if (jpeg == nullptr || out == nullptr || bin < 1 || bin > kMaxBinning) return Status::kInvalidArgument;
  if (state_ == nullptr) return Status::kUnsupported;
  State* s = state_;
  s->truncated = false;
  s->exhausted = false;
  s->used = 0;
  s->message[0] = '\0';
  jpeg_decompress_struct* cinfo = &s->cinfo;
  if (setjmp(s->jump) != 0) {
    jpeg_abort_decompress(cinfo);
    std::snprintf(last_error_, sizeof(last_error_), "%s", s->message);
    if (s->exhausted) return Status::kCapacityExceeded;
    return s->truncated ? Status::kTruncated : Status::kCorruptData;
  }
  jpeg_mem_src(cinfo, jpeg, static_cast<unsigned long>(jpeg_bytes));
  if (jpeg_read_header(cinfo, TRUE) != JPEG_HEADER_OK) {
    jpeg_abort_decompress(cinfo);
    return Status::kTruncated;
  }
  width = static_cast<int32_t>(cinfo->image_width);
  height = static_cast<int32_t>(cinfo->image_height);
  const bool fits = bin == 1 ? static_cast<std::size_t>(width) * static_cast<std::size_t>(height) <= capacity_bytes
                             : s->binner.begin(width, height, bin, out, capacity_bytes);
  if (!fits) {
    jpeg_abort_decompress(cinfo);
    return Status::kCapacityExceeded;
  }
  cinfo->out_color_space = JCS_GRAYSCALE;
  jpeg_start_decompress(cinfo);
  const std::size_t stride = static_cast<std::size_t>(width);
  // Binned: each line is decoded into one line of the arena (image pool, released with the image) and
  // added to the block sums; unbinned: straight into the caller's buffer.
  JSAMPROW line = bin == 1 ? nullptr
                           : static_cast<JSAMPROW>((*cinfo->mem->alloc_small)(
                                 reinterpret_cast<j_common_ptr>(cinfo), JPOOL_IMAGE, stride));
  while (cinfo->output_scanline < cinfo->output_height) {
    JSAMPROW row = bin == 1 ? out + static_cast<std::size_t>(cinfo->output_scanline) * stride : line;
    if (jpeg_read_scanlines(cinfo, &row, 1) != 1) break;
    if (bin != 1) s->binner.addLine(line);
  }
  const bool truncated = s->truncated;
  jpeg_finish_decompress(cinfo);
  if (s->high_water > high_water_) high_water_ = s->high_water;
  if (truncated) {
    std::snprintf(last_error_, sizeof(last_error_), "premature end of JPEG data");
    return Status::kTruncated;
  }
  return Status::kOk;
}

Status ArenaJpegDecoder::encodeGray(const uint8_t*, int32_t, int32_t, int32_t, uint8_t*, std::size_t,
                                    std::size_t& encoded_bytes) {
  encoded_bytes = 0;
  return Status::kUnsupported;
}

std::size_t ArenaJpegDecoder::maxEncodedBytes(int32_t width, int32_t height) const {
  return static_cast<std::size_t>(width) * static_cast<std::size_t>(height) + 2048u;
}

}  // namespace areomap::platform
