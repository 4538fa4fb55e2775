#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include "ground/dem/KeyOrder.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dem;

namespace {

// As the DEM binning's points: a cell (row, column) first, then the place in the cloud.
struct KeyOrderItem {
  int row, col;
  std::size_t place;
  bool operator<(const KeyOrderItem& o) const {
    return row != o.row ? row < o.row : col != o.col ? col < o.col : place < o.place;
  }
  bool operator==(const KeyOrderItem& o) const { return row == o.row && col == o.col && place == o.place; }
};

// n items on a rows x cols grid; `shuffled`: the places not in increasing order (the check must catch it).
std::vector<KeyOrderItem> keyOrderItems(std::mt19937& rng, std::size_t n, int rows, int cols, bool shuffled) {
  std::uniform_int_distribution<int> r(-rows / 2, rows - rows / 2 - 1), c(-1, cols);
  std::vector<KeyOrderItem> items(n);
  for (std::size_t i = 0; i < n; ++i) items[i] = KeyOrderItem{r(rng), c(rng), i};
  if (shuffled) std::shuffle(items.begin(), items.end(), rng);
  return items;
}

}  // namespace

TEST_GROUP(KeyOrder){};

// Counted (narrow keys), sorted (keys too wide), places out of order within a key (the check falls back),
// keys that collide across rows (columns beyond the width): every result is std::sort's.
TEST(KeyOrder, SameOrderAsStdSort) {
  struct Case {
    int cols, rows;
    bool shuffled;
  };
  std::vector<Case> grid_cases;
  for (const int cols : {1, 7, 40})
    for (const int rows : {1, 5, 3000})
      for (const bool shuffled : {false, true}) grid_cases.push_back(Case{cols, rows, shuffled});
  std::mt19937 rng(3);
  int checked = 0;
  for (const Case& k : grid_cases) {
    for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{2}, std::size_t{500}}) {
      std::vector<KeyOrderItem> items = keyOrderItems(rng, n, k.rows, k.cols, k.shuffled);
      std::vector<KeyOrderItem> expected = items;
      std::sort(expected.begin(), expected.end());
      const long long width = k.cols;  // columns -1 and cols collide with the rows beside
      keyOrder(
          items, [&](const KeyOrderItem& t) { return t.row * width + t.col; },
          [](const KeyOrderItem& a, const KeyOrderItem& b) { return a < b; });
      CHECK(items == expected);
      ++checked;
    }
  }
  CHECK_EQUAL(72, checked);
}
