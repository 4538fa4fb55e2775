#include "platform/heap/HeapCounter.hpp"

#include <atomic>
#include <cerrno>
#include <cstddef>

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define AREOMAP_HEAP_COUNTER_DISABLED 1
#endif
#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define AREOMAP_HEAP_COUNTER_DISABLED 1
#endif
#endif

namespace {
std::atomic<uint64_t> g_allocations{0};
std::atomic<uint64_t> g_frees{0};
// initial-exec TLS: reading it never calls into the dynamic loader (which could allocate).
__attribute__((tls_model("initial-exec"))) thread_local uint64_t t_allocations = 0;

inline void countAllocation() {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  ++t_allocations;
}
}  // namespace

namespace areomap {

#ifdef AREOMAP_HEAP_COUNTER_DISABLED
bool heapCounterActive() { return false; }
#else
bool heapCounterActive() { return true; }
#endif
uint64_t heapAllocationCount() { return g_allocations.load(std::memory_order_relaxed); }
uint64_t heapFreeCount() { return g_frees.load(std::memory_order_relaxed); }
uint64_t heapAllocationCountThisThread() { return t_allocations; }

}  // namespace areomap

#ifndef AREOMAP_HEAP_COUNTER_DISABLED
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t count, std::size_t size);
void* __libc_realloc(void* ptr, std::size_t size);
void __libc_free(void* ptr);
void* __libc_memalign(std::size_t alignment, std::size_t size);

void* malloc(std::size_t size) {
  countAllocation();
  return __libc_malloc(size);
}
void* calloc(std::size_t count, std::size_t size) {
  countAllocation();
  return __libc_calloc(count, size);
}
void* realloc(void* ptr, std::size_t size) {
  countAllocation();
  return __libc_realloc(ptr, size);
}
void free(void* ptr) {
  if (ptr != nullptr) g_frees.fetch_add(1, std::memory_order_relaxed);
  __libc_free(ptr);
}
void* memalign(std::size_t alignment, std::size_t size) {
  countAllocation();
  return __libc_memalign(alignment, size);
}
void* aligned_alloc(std::size_t alignment, std::size_t size) {
  countAllocation();
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t size) {
  countAllocation();
  if (alignment < sizeof(void*) || (alignment & (alignment - 1)) != 0) return EINVAL;
  void* p = __libc_memalign(alignment, size);
  if (p == nullptr) return ENOMEM;
  *out = p;
  return 0;
}
void* valloc(std::size_t size) {
  countAllocation();
  return __libc_memalign(4096, size);
}
}  // extern "C"
#endif
