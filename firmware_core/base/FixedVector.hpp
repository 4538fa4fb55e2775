// A fixed-capacity array that says when it is full: push() returns false and counts the overflow, which
// status telemetry reports (after PX4 containers/Array.hpp). No heap, ever.
#pragma once

#include <cstdint>

namespace areomap {

template <typename T, int32_t N>
class FixedVector {
 public:
  static_assert(N > 0, "capacity must be positive");

  [[nodiscard]] bool push(const T& value) {
    if (size_ >= N) {
      ++overflow_count_;
      return false;
    }
    items_[size_++] = value;
    return true;
  }
  void pop() {
    if (size_ > 0) --size_;
  }
  void clear() { size_ = 0; }
  // Drops the counted overflows too (start of a new panorama).
  void reset() {
    size_ = 0;
    overflow_count_ = 0;
  }
  // Shrinks to `n` elements (n <= size()).
  void truncate(int32_t n) {
    if (n >= 0 && n < size_) size_ = n;
  }

  int32_t size() const { return size_; }
  static constexpr int32_t capacity() { return N; }
  bool empty() const { return size_ == 0; }
  bool full() const { return size_ >= N; }
  uint32_t overflowCount() const { return overflow_count_; }

  T& operator[](int32_t i) { return items_[i]; }
  const T& operator[](int32_t i) const { return items_[i]; }
  T& back() { return items_[size_ - 1]; }
  const T& back() const { return items_[size_ - 1]; }
  T* begin() { return items_; }
  T* end() { return items_ + size_; }
  const T* begin() const { return items_; }
  const T* end() const { return items_ + size_; }
  T* data() { return items_; }
  const T* data() const { return items_; }

 private:
  T items_[N]{};
  int32_t size_ = 0;
  uint32_t overflow_count_ = 0;
};

}  // namespace areomap
