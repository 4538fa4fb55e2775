#include <cstring>
#include <deque>
#include <vector>

#include "firmware_core/node/ByteRing.hpp"
#include "platform/heap/HeapCounter.hpp"

#include <CppUTest/TestHarness.h>

using areomap::ByteRing;

namespace {
uint8_t g_storage[4096];
}

TEST_GROUP(ByteRing){};

// Records come out in order with their bytes and tags, across many wrap-arounds, against a std::deque model;
// a record that does not fit is refused and counted; no heap.
TEST(ByteRing, FifoAgainstAModelWithWrapAndRefusal) {
  ByteRing ring(g_storage, sizeof(g_storage));
  std::deque<std::vector<uint8_t>> model;
  std::vector<uint8_t> scratch(1200);
  uint64_t refused = 0;
  uint32_t rng = 12345;
  for (int step = 0; step < 5000; ++step) {
    rng = rng * 1103515245u + 12345u;
    const bool push = (rng >> 16) % 3 != 0;
    if (push) {
      const std::size_t size = (rng >> 8) % 1200;
      for (std::size_t i = 0; i < size; ++i) scratch[i] = static_cast<uint8_t>(step + i);
      areomap::HeapAllocationScope scope;
      const bool ok = ring.push(static_cast<uint8_t>(step & 0xFF), scratch.data(), size);
      CHECK_EQUAL(0u, scope.allocations());
      if (ok) {
        std::vector<uint8_t> rec(scratch.begin(), scratch.begin() + static_cast<long>(size));
        rec.push_back(static_cast<uint8_t>(step & 0xFF));  // tag last
        model.push_back(rec);
      } else {
        ++refused;
      }
    } else if (!model.empty()) {
      uint8_t tag = 0;
      const uint8_t* data = nullptr;
      std::size_t size = 0;
      CHECK_TRUE(ring.front(tag, data, size));
      const std::vector<uint8_t>& expect = model.front();
      CHECK_EQUAL(expect.size() - 1, size);
      CHECK_EQUAL(expect.back(), tag);
      CHECK_EQUAL(0, std::memcmp(expect.data(), data, size));
      ring.pop();
      model.pop_front();
    }
    CHECK_EQUAL(model.size(), ring.records());
  }
  CHECK_EQUAL(refused, ring.refused());
  CHECK_TRUE(refused > 0);  // the ring was full at times
  uint8_t tag = 0;
  const uint8_t* data = nullptr;
  std::size_t size = 0;
  while (!model.empty()) {
    CHECK_TRUE(ring.front(tag, data, size));
    CHECK_EQUAL(model.front().size() - 1, size);
    ring.pop();
    model.pop_front();
  }
  CHECK_FALSE(ring.front(tag, data, size));
  CHECK_FALSE(ring.push(0, scratch.data(), sizeof(g_storage)));  // larger than the whole ring
}
