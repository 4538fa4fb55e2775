#include "platform/heap/HeapCounter.hpp"

#include <execinfo.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#if AREOMAP_SANITIZER_BUILD
#define AREOMAP_HEAP_COUNTER_DISABLED 1
#endif

namespace {
std::atomic<uint64_t> g_allocations{0};
std::atomic<uint64_t> g_frees{0};
// initial-exec TLS: reading it never calls into the dynamic loader (which could allocate).
__attribute__((tls_model("initial-exec"))) thread_local uint64_t t_allocations = 0;

// Allocation tracing (HeapCounter.hpp): static records, filled by the armed threads' allocations.
struct TraceRecord {
  void* frames[areomap::kHeapTraceFrames];
  int depth;
  const char* function;
  std::size_t size;
  uint64_t thread_count;  // the thread's allocation count at this allocation
};
TraceRecord g_trace[areomap::kHeapTraceRecords];
std::atomic<uint64_t> g_trace_recorded{0};
std::atomic<bool> g_trace_exit_registered{false};
__attribute__((tls_model("initial-exec"))) thread_local bool t_trace_armed = false;
__attribute__((tls_model("initial-exec"))) thread_local bool t_in_trace = false;

[[maybe_unused]] void recordAllocation(const char* function, std::size_t size) {
  if (!t_trace_armed || t_in_trace) return;
  t_in_trace = true;  // backtrace() may allocate (it does not once warmed up); those are not recorded
  const uint64_t index = g_trace_recorded.fetch_add(1, std::memory_order_relaxed);
  if (index < static_cast<uint64_t>(areomap::kHeapTraceRecords)) {
    TraceRecord& r = g_trace[index];
    r.depth = backtrace(r.frames, areomap::kHeapTraceFrames);
    r.function = function;
    r.size = size;
    r.thread_count = t_allocations;
  }
  t_in_trace = false;
}

inline void countAllocation(const char* function, std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  ++t_allocations;
  recordAllocation(function, size);
}

void writeText(const char* text) {  // no stdio (no heap): one write of a short line
  if (write(STDERR_FILENO, text, std::strlen(text)) < 0) return;
}

[[maybe_unused]] void printTraceAtExit() { areomap::heapTracePrint(); }
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

bool heapTraceArmThisThread() {
#ifdef AREOMAP_HEAP_COUNTER_DISABLED
  return false;
#else
  const char* env = std::getenv("AREOMAP_HEAP_TRACE");
  if (env == nullptr || env[0] == '\0' || std::strcmp(env, "0") == 0) return false;
  void* warm[2];
  (void)backtrace(warm, 2);  // loads libgcc_s now, not at the first traced allocation
  if (!g_trace_exit_registered.exchange(true)) std::atexit(printTraceAtExit);
  t_trace_armed = true;
  return true;
#endif
}

uint64_t heapTraceRecorded() { return g_trace_recorded.load(std::memory_order_relaxed); }

void heapTracePrint() {
  const uint64_t recorded = heapTraceRecorded();
  char line[200];
  std::snprintf(line, sizeof(line), "heap trace: %llu allocation(s) of armed threads after their mark\n",
                static_cast<unsigned long long>(recorded));
  writeText(line);
  const uint64_t shown = recorded < static_cast<uint64_t>(kHeapTraceRecords) ? recorded : kHeapTraceRecords;
  for (uint64_t i = 0; i < shown; ++i) {
    const TraceRecord& r = g_trace[i];
    std::snprintf(line, sizeof(line), "heap trace #%llu: %s(%zu), the thread's allocation #%llu, %d frames:\n",
                  static_cast<unsigned long long>(i), r.function, r.size,
                  static_cast<unsigned long long>(r.thread_count), r.depth);
    writeText(line);
    backtrace_symbols_fd(r.frames, r.depth, STDERR_FILENO);
  }
}

}  // namespace areomap

#ifndef AREOMAP_HEAP_COUNTER_DISABLED
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t count, std::size_t size);
void* __libc_realloc(void* ptr, std::size_t size);
void __libc_free(void* ptr);
void* __libc_memalign(std::size_t alignment, std::size_t size);

void* malloc(std::size_t size) {
  countAllocation("malloc", size);
  return __libc_malloc(size);
}
void* calloc(std::size_t count, std::size_t size) {
  countAllocation("calloc", count * size);
  return __libc_calloc(count, size);
}
void* realloc(void* ptr, std::size_t size) {
  countAllocation("realloc", size);
  return __libc_realloc(ptr, size);
}
void free(void* ptr) {
  if (ptr != nullptr) g_frees.fetch_add(1, std::memory_order_relaxed);
  __libc_free(ptr);
}
void* memalign(std::size_t alignment, std::size_t size) {
  countAllocation("memalign", size);
  return __libc_memalign(alignment, size);
}
void* aligned_alloc(std::size_t alignment, std::size_t size) {
  countAllocation("aligned_alloc", size);
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t size) {
  countAllocation("posix_memalign", size);
  if (alignment < sizeof(void*) || (alignment & (alignment - 1)) != 0) return EINVAL;
  void* p = __libc_memalign(alignment, size);
  if (p == nullptr) return ENOMEM;
  *out = p;
  return 0;
}
void* valloc(std::size_t size) {
  countAllocation("valloc", size);
  return __libc_memalign(4096, size);
}
}  // extern "C"
#endif
