// The simulator's parallel loops: the ground's (ground/cli/Parallel.hpp), fn(i) for i in [0, count) on
// `threads` threads (0 = the process-wide setting, every core by default). Work items must be independent
// so that results do not depend on the thread count.
#pragma once

#include <cstddef>

#include "ground/cli/Parallel.hpp"

namespace areomap::sim {

using cli::threadCount;

template <typename Fn>
void parallelFor(int count, int threads, Fn&& fn) {
  cli::parallelFor(static_cast<std::size_t>(count > 0 ? count : 0), threads,
                   [&fn](std::size_t i) { fn(static_cast<int>(i)); });
}

}  // namespace areomap::sim
