// The ground's threads: one process-wide thread count (the tools' --threads N, default every core) and a
// parallel for over independent work items. Deterministic by construction: item i writes only its own
// slot, and whatever is merged is merged afterwards in item order, so that the products are the same
// bytes for any thread count. Header only: every ground library uses it without linking the tools' front
// end.
#pragma once

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace areomap::cli {

inline constexpr int kMaxThreads = 256;  // beyond any ground station's cores; a bad --threads is refused

namespace detail {
inline std::atomic<int>& threadSetting() {
  static std::atomic<int> threads{0};  // 0: every core
  return threads;
}
}  // namespace detail

// Sets the process-wide thread count (0: every core). Called once by a tool's main before any work.
inline void setThreads(int threads) {
  detail::threadSetting().store(std::clamp(threads, 0, kMaxThreads));
}

// The threads to use: `requested` when > 0, else the process-wide setting, else every core (at least 1).
inline int threadCount(int requested = 0) {
  if (requested > 0) return std::min(requested, kMaxThreads);
  const int set = detail::threadSetting().load();
  if (set > 0) return set;
  const unsigned hw = std::thread::hardware_concurrency();
  return hw == 0 ? 1 : static_cast<int>(std::min<unsigned>(hw, kMaxThreads));
}

// Runs fn(i) for i in [0, count) on threadCount(threads) threads (never more than count), items handed out
// in increasing order from a shared counter. The first exception (by item index) is rethrown here after
// every thread has stopped; items not yet started are then skipped.
template <typename Fn>
void parallelFor(std::size_t count, int threads, Fn&& fn) {
  const std::size_t n = std::min<std::size_t>(static_cast<std::size_t>(threadCount(threads)), count);
  if (n <= 1) {
    for (std::size_t i = 0; i < count; ++i) fn(i);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::mutex m;
  std::size_t failed_at = count;
  std::exception_ptr error;
  const auto worker = [&] {
    for (std::size_t i = next.fetch_add(1); i < count && !failed.load(); i = next.fetch_add(1)) {
      try {
        fn(i);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(m);
        if (i < failed_at) {
          failed_at = i;
          error = std::current_exception();
        }
        failed.store(true);
      }
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(n - 1);
  for (std::size_t t = 1; t < n; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

// Items made in parallel and used in item order: result = make(i) runs on threadCount(threads) threads,
// use(i, std::move(result)) runs for each item once every item before it has been used, one use at a time
// (so `use` may append to shared output unguarded). At most the threads' items wait made and unused: the
// items are handed out in increasing order, so the lowest one in flight never waits. An exception of
// make(i) or use(i) is rethrown in item order, after the items before i were used.
template <typename Make, typename Use>
void orderedFor(std::size_t count, int threads, Make&& make, Use&& use) {
  std::mutex m;
  std::condition_variable turn;
  std::size_t next_use = 0;
  parallelFor(count, threads, [&](std::size_t i) {
    std::exception_ptr error;
    decltype(make(i)) made{};
    try {
      made = make(i);
    } catch (...) {
      error = std::current_exception();
    }
    std::unique_lock<std::mutex> lock(m);
    turn.wait(lock, [&] { return next_use == i; });
    struct Advance {  // the next item's turn, also when this one throws
      std::size_t& next;
      std::condition_variable& cv;
      ~Advance() {
        ++next;
        cv.notify_all();
      }
    } advance{next_use, turn};
    if (error) std::rethrow_exception(error);
    use(i, std::move(made));
  });
}

}  // namespace areomap::cli
