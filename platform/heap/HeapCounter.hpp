// Counts heap allocations of the whole process by interposing malloc, calloc, realloc, free and the
// aligned variants, forwarding to glibc (__libc_*). Works in the Release build, where Eigen's
// EIGEN_RUNTIME_NO_MALLOC is compiled out, and counts every allocation: operator new, Eigen, STL, libc.
//
// Linking `areomap_heap_counter` into an executable turns the counter on (its malloc definitions
// interpose glibc's); a build with sanitizers, which own malloc themselves, compiles the interposer out and
// heapCounterActive() is false.
#pragma once

#include <cstdint>

// 1 in a translation unit compiled with a sanitizer that owns malloc (GCC's __SANITIZE_* or clang's
// __has_feature), else 0. The counter compiles itself out there; tests that assert on it skip.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define AREOMAP_SANITIZER_BUILD 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define AREOMAP_SANITIZER_BUILD 1
#endif
#endif
#ifndef AREOMAP_SANITIZER_BUILD
#define AREOMAP_SANITIZER_BUILD 0
#endif

namespace areomap {

// True when allocations are being counted in this process.
bool heapCounterActive();
// Allocation calls (malloc, calloc, realloc, memalign, posix_memalign, aligned_alloc, valloc) so far.
uint64_t heapAllocationCount();
// free calls with a non-null pointer so far.
uint64_t heapFreeCount();
// Allocation calls made by the calling thread so far. A node whose transport library allocates on its own
// thread (LCM's receive thread) proves its pipeline thread heap-free with this count.
uint64_t heapAllocationCountThisThread();

// Allocation tracing, for finding an allocation that a count shows: when the environment variable
// AREOMAP_HEAP_TRACE is set (to anything but "0") at the first call, heapTraceArmThisThread() makes every
// later allocation of the calling thread record its call stack (glibc backtrace(), into a static buffer of
// kHeapTraceRecords records, no heap), and the records are printed to stderr at exit (backtrace_symbols_fd:
// "binary(symbol+offset) [address]"; resolve offsets in the binary with addr2line -f -C -e BINARY OFFSET).
// Without the variable it does nothing. Returns true when tracing is on. Call it at the thread's start-up
// mark, before the count that must stay 0: it warms backtrace() up (its first call loads libgcc_s).
bool heapTraceArmThisThread();
// Allocations recorded so far (also those beyond the buffer's capacity).
uint64_t heapTraceRecorded();
// Prints the records to stderr now (also done at exit once armed); clears nothing.
void heapTracePrint();
constexpr int kHeapTraceRecords = 16;
constexpr int kHeapTraceFrames = 24;

// Measures the allocations made between construction and allocations().
class HeapAllocationScope {
 public:
  HeapAllocationScope() : start_(heapAllocationCount()) {}
  uint64_t allocations() const { return heapAllocationCount() - start_; }

 private:
  uint64_t start_;
};

}  // namespace areomap
