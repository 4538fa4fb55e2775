// A FIFO of variable-size records in one caller-provided byte buffer (no heap): the hand-over between the
// rover's transport thread and its pipeline thread. Not thread-safe by itself: the caller locks.
// A record that does not fit the free space is refused (push returns false) and counted.
#pragma once

#include <cstddef>
#include <cstdint>

namespace areomap {

class ByteRing {
 public:
  ByteRing(uint8_t* storage, std::size_t capacity) : storage_(storage), capacity_(capacity) {}

  // Appends a record of `size` bytes with a small tag (e.g. a channel index). false when it does not fit.
  bool push(uint8_t tag, const uint8_t* data, std::size_t size);
  // The oldest record (valid until pop()); false when empty.
  bool front(uint8_t& tag, const uint8_t*& data, std::size_t& size) const;
  void pop();

  std::size_t records() const { return records_; }
  std::size_t usedBytes() const { return used_; }
  uint64_t refused() const { return refused_; }
  std::size_t capacity() const { return capacity_; }

  static constexpr std::size_t kHeaderBytes = 16;  // size (8), tag (1), padding
  // Ring bytes a record of `size` bytes takes: its header and the data rounded up to 8 bytes.
  static constexpr std::size_t recordBytes(std::size_t size) {
    return kHeaderBytes + ((size + 7u) & ~std::size_t{7});
  }

 private:
  uint8_t* storage_;
  std::size_t capacity_;
  std::size_t head_ = 0;   // oldest record
  std::size_t tail_ = 0;   // where the next record goes
  std::size_t wrap_ = 0;   // end of valid data when the tail has wrapped (0 = not wrapped)
  std::size_t used_ = 0;
  std::size_t records_ = 0;
  uint64_t refused_ = 0;
};

}  // namespace areomap
