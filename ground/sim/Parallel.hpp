// Runs fn(i) for i in [0, count) on `threads` threads (0 = all cores), taking indices from a shared
// counter. Work items must be independent so that results do not depend on the thread count.
#pragma once

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

namespace areomap::sim {

inline int threadCount(int requested) {
  if (requested > 0) return requested;
  const unsigned hw = std::thread::hardware_concurrency();
  return hw == 0 ? 1 : static_cast<int>(hw);
}

template <typename Fn>
void parallelFor(int count, int threads, Fn&& fn) {
  const int n = std::max(1, std::min(threadCount(threads), count));
  std::atomic<int> next{0};
  auto worker = [&] {
    for (int i = next.fetch_add(1); i < count; i = next.fetch_add(1)) fn(i);
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < n; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
}

}  // namespace areomap::sim
