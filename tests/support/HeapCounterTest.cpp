#include <cstdio>
#include <cstdlib>
#include <thread>
#include <vector>

#include "firmware_core/base/EigenTypes.hpp"
#include "platform/heap/HeapCounter.hpp"

#include <CppUTest/TestHarness.h>

using areomap::HeapAllocationScope;

namespace {
// Kept out of the optimiser's reach so that the allocations below really happen.
void* volatile g_sink = nullptr;
}  // namespace

// In a sanitizer build the counter is compiled out (the sanitizer owns malloc): the group says so and
// checks only that; elsewhere the counter must be on and count.
TEST_GROUP(HeapCounter) {
  bool skipped() {
    if (!AREOMAP_SANITIZER_BUILD) return false;
    CHECK_FALSE(areomap::heapCounterActive());
    std::printf("SKIP: sanitizer build, the heap counter is compiled out\n");
    return true;
  }
};

TEST(HeapCounter, IsActiveInThisBuild) {
  if (skipped()) return;
  CHECK_TRUE(areomap::heapCounterActive());
}

TEST(HeapCounter, CatchesMallocNewAndVector) {
  if (skipped()) return;
  {
    HeapAllocationScope scope;
    void* p = std::malloc(64);
    g_sink = p;
    std::free(p);
    CHECK_EQUAL(1u, scope.allocations());
  }
  {
    HeapAllocationScope scope;
    int* p = new int[16];
    g_sink = p;
    delete[] p;
    CHECK_EQUAL(1u, scope.allocations());
  }
  {
    HeapAllocationScope scope;
    std::vector<double> v(1000, 1.0);
    g_sink = v.data();
    CHECK(scope.allocations() >= 1u);
  }
  {
    HeapAllocationScope scope;
    Eigen::MatrixXd m = Eigen::MatrixXd::Identity(20, 20);
    g_sink = m.data();
    CHECK(scope.allocations() >= 1u);
  }
  {
    HeapAllocationScope scope;
    void* p = std::aligned_alloc(64, 256);
    g_sink = p;
    std::free(p);
    void* q = nullptr;
    CHECK_EQUAL(0, posix_memalign(&q, 64, 256));
    std::free(q);
    p = std::calloc(4, 8);
    p = std::realloc(p, 128);
    g_sink = p;
    std::free(p);
    CHECK_EQUAL(4u, scope.allocations());
  }
}

TEST(HeapCounter, ReportsZeroForFixedSizeWork) {
  if (skipped()) return;
  HeapAllocationScope scope;
  areomap::Mat12 a = areomap::Mat12::Identity() * 2.0;
  areomap::Vec12 b = areomap::Vec12::Ones();
  areomap::Vec12 x = a.ldlt().solve(b);
  g_sink = &x;
  DOUBLES_EQUAL(0.5, x(3), 1e-15);
  CHECK_EQUAL(0u, scope.allocations());
}

TEST(HeapCounter, CountsPerThread) {
  if (skipped()) return;
  const uint64_t mine = areomap::heapAllocationCountThisThread();
  const uint64_t all = areomap::heapAllocationCount();
  std::thread other([] {
    for (int i = 0; i < 10; ++i) {
      void* p = std::malloc(32);
      g_sink = p;
      std::free(p);
    }
  });
  other.join();
  // Starting a thread allocates on this thread too (its control block); the other thread's ten mallocs are
  // not counted here.
  CHECK(areomap::heapAllocationCount() - all >= 10u);
  CHECK(areomap::heapAllocationCountThisThread() - mine < 10u);
}

// AREOMAP_HEAP_TRACE=1: an armed thread records the call stack of each allocation after its mark; other
// threads and the time before arming are not recorded.
TEST(HeapCounter, TraceRecordsTheArmedThreadsAllocations) {
  if (skipped()) return;
  CHECK_EQUAL(0, setenv("AREOMAP_HEAP_TRACE", "1", 1));
  const uint64_t before = areomap::heapTraceRecorded();
  void* q = std::malloc(24);  // this thread is not armed
  g_sink = q;
  std::free(q);
  bool armed = false;
  uint64_t allocations_after_mark = 0;
  std::thread traced([&] {
    armed = areomap::heapTraceArmThisThread();
    const uint64_t mark = areomap::heapAllocationCountThisThread();
    for (int i = 0; i < 3; ++i) {
      void* p = std::malloc(40 + i);
      g_sink = p;
      std::free(p);
    }
    allocations_after_mark = areomap::heapAllocationCountThisThread() - mark;
  });
  traced.join();
  CHECK_EQUAL(0, unsetenv("AREOMAP_HEAP_TRACE"));
  CHECK_TRUE(armed);
  CHECK_EQUAL(3u, allocations_after_mark);
  CHECK_EQUAL(3u, areomap::heapTraceRecorded() - before);
  // Without the variable, arming does nothing.
  std::thread untraced([&] { armed = areomap::heapTraceArmThisThread(); });
  untraced.join();
  CHECK_FALSE(armed);
}
