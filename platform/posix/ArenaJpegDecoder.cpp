#include "platform/posix/ArenaJpegDecoder.hpp"

#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <new>

#include <jpeglib.h>
// jerror.h after jpeglib.h: message codes and ERREXIT.
#include <jerror.h>

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
  if (pool_id == JPOOL_IMAGE) s->used = 0;
  // JPOOL_PERMANENT: freed by self_destruct through libjpeg's own function (jpeg_destroy).
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
  return Status::kOk;
}

Status ArenaJpegDecoder::decodeGray(const uint8_t* jpeg, std::size_t jpeg_bytes, uint8_t* out,
                                    std::size_t capacity_bytes, int32_t& width, int32_t& height) {
  if (jpeg == nullptr || out == nullptr) return Status::kInvalidArgument;
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
  if (static_cast<std::size_t>(width) * static_cast<std::size_t>(height) > capacity_bytes) {
    jpeg_abort_decompress(cinfo);
    return Status::kCapacityExceeded;
  }
  cinfo->out_color_space = JCS_GRAYSCALE;
  jpeg_start_decompress(cinfo);
  const std::size_t stride = static_cast<std::size_t>(width);
  while (cinfo->output_scanline < cinfo->output_height) {
    JSAMPROW row = out + static_cast<std::size_t>(cinfo->output_scanline) * stride;
    if (jpeg_read_scanlines(cinfo, &row, 1) != 1) break;
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
