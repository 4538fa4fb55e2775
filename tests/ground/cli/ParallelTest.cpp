#include <atomic>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

#include "ground/cli/Parallel.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

TEST_GROUP(Parallel){void teardown() override{cli::setThreads(0);
}
}
;

// Every item runs once, whatever the thread count, and the threads used never exceed the items.
TEST(Parallel, EveryItemOnceForAnyThreadCount) {
  for (int threads : {1, 2, 3, 8}) {
    std::vector<std::atomic<int>> runs(100);
    cli::parallelFor(runs.size(), threads, [&](std::size_t i) { ++runs[i]; });
    for (const std::atomic<int>& r : runs) CHECK_EQUAL(1, r.load());
  }
  int ran = 0;
  cli::parallelFor(0, 4, [&](std::size_t) { ++ran; });
  CHECK_EQUAL(0, ran);
}

// The process-wide setting (the tools' --threads) is what 0 asks for; an explicit count wins.
TEST(Parallel, ProcessWideSetting) {
  cli::setThreads(3);
  CHECK_EQUAL(3, cli::threadCount());
  CHECK_EQUAL(5, cli::threadCount(5));
  cli::setThreads(0);
  CHECK(cli::threadCount() >= 1);
}

// orderedFor hands the items on in item order, whatever order they finish in.
TEST(Parallel, OrderedForUsesItemsInOrder) {
  for (int threads : {1, 2, 4}) {
    std::vector<std::size_t> used;
    cli::orderedFor(
        50, threads,
        [](std::size_t i) {
          volatile double x = 0;  // later items finish sooner
          for (std::size_t k = 0; k < (50 - i) * 2000; ++k) x = x + 1.0;
          return i * 10;
        },
        [&](std::size_t i, std::size_t made) {
          CHECK_EQUAL(i * 10, made);
          used.push_back(i);
        });
    CHECK_EQUAL(50u, used.size());
    for (std::size_t i = 0; i < used.size(); ++i) CHECK_EQUAL(i, used[i]);
  }
}

// A failing item: its exception reaches the caller after the items before it were used, and no item after
// it is used before it.
TEST(Parallel, FailureRethrownInItemOrder) {
  for (int threads : {1, 2, 4}) {
    std::vector<std::size_t> used;
    std::string what;
    try {
      cli::orderedFor(
          20, threads,
          [](std::size_t i) {
            if (i == 7) throw std::runtime_error("item 7");
            return i;
          },
          [&](std::size_t i, std::size_t) { used.push_back(i); });
    } catch (const std::runtime_error& e) {
      what = e.what();
    }
    STRCMP_EQUAL("item 7", what.c_str());
    CHECK(used.size() >= 7);
    for (std::size_t i = 0; i < 7; ++i) CHECK_EQUAL(i, used[i]);
    for (std::size_t i = 7; i < used.size(); ++i) CHECK(used[i] > 7);
  }
}
