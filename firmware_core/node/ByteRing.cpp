#include "firmware_core/node/ByteRing.hpp"

#include <cstring>

namespace areomap {

bool ByteRing::push(uint8_t tag, const uint8_t* data, std::size_t size) {
  const std::size_t need = recordBytes(size);
  std::size_t at = tail_;
  if (records_ == 0) {
    head_ = tail_ = wrap_ = 0;
    at = 0;
  }
  if (records_ > 0 && wrap_ == 0 && tail_ >= head_) {
    // Free space: [tail, capacity) and, after wrapping, [0, head).
    if (capacity_ - tail_ < need) {
      if (head_ < need) {
        refused_ += 1;
        return false;
      }
      wrap_ = tail_;
      at = 0;
    }
  } else if (records_ > 0) {
    // Wrapped: free space is [tail, head).
    if (head_ - tail_ < need) {
      refused_ += 1;
      return false;
    }
  } else if (capacity_ < need) {
    refused_ += 1;
    return false;
  }
  uint64_t s = size;
  std::memcpy(storage_ + at, &s, sizeof(s));
  storage_[at + 8] = tag;
  if (size > 0) std::memcpy(storage_ + at + kHeaderBytes, data, size);
  tail_ = at + need;
  used_ += need;
  records_ += 1;
  return true;
}

bool ByteRing::front(uint8_t& tag, const uint8_t*& data, std::size_t& size) const {
  if (records_ == 0) return false;
  std::size_t at = head_;
  if (wrap_ != 0 && at == wrap_) at = 0;
  uint64_t s = 0;
  std::memcpy(&s, storage_ + at, sizeof(s));
  tag = storage_[at + 8];
  data = storage_ + at + kHeaderBytes;
  size = static_cast<std::size_t>(s);
  return true;
}

void ByteRing::pop() {
  if (records_ == 0) return;
  if (wrap_ != 0 && head_ == wrap_) {
    head_ = 0;
    wrap_ = 0;
  }
  uint64_t s = 0;
  std::memcpy(&s, storage_ + head_, sizeof(s));
  const std::size_t need = recordBytes(static_cast<std::size_t>(s));
  head_ += need;
  used_ -= need;
  records_ -= 1;
  if (wrap_ != 0 && head_ == wrap_) {
    head_ = 0;
    wrap_ = 0;
  }
}

}  // namespace areomap
