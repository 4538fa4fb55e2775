// The order std::sort gives, by counting where it is cheaper (the DEM binning's points, BinnedCloud.cpp).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace areomap::dem {

// Orders `items` by `less` (a strict order under which no two items are equivalent, so that the sorted order
// is unique: std::sort's). `key(item)`: an integer key, meant to be one that `less` orders first. When the
// keys of the items span at most kKeyOrderSpan values per item, the items are counted into their keys'
// places in one stable pass (items of one key keep their order), and the result is checked against `less`:
// it stands when the key orders first and the items of each key came in `less`'s order (the caller's usual
// case), else std::sort decides. The same order either way.
inline constexpr std::size_t kKeyOrderSpan = 4;  // a count per key value: wider spans cost more than a sort

template <class T, class Key, class Less>
void keyOrder(std::vector<T>& items, const Key& key, const Less& less) {
  const std::size_t n = items.size();
  if (n < 2) return;
  long long lo = key(items[0]), hi = lo;
  for (const T& t : items) {
    const long long k = key(t);
    lo = std::min(lo, k);
    hi = std::max(hi, k);
  }
  const unsigned long long span = static_cast<unsigned long long>(hi - lo) + 1;
  if (span > kKeyOrderSpan * n || n > UINT32_MAX) {
    std::sort(items.begin(), items.end(), less);
    return;
  }
  std::vector<uint32_t> counts(static_cast<std::size_t>(span) + 1, 0);
  for (const T& t : items) ++counts[static_cast<std::size_t>(key(t) - lo) + 1];
  for (std::size_t k = 1; k < counts.size(); ++k) counts[k] += counts[k - 1];
  std::vector<T> scratch(n);
  for (const T& t : items) scratch[counts[static_cast<std::size_t>(key(t) - lo)]++] = t;
  items.swap(scratch);
  if (!std::is_sorted(items.begin(), items.end(), less)) std::sort(items.begin(), items.end(), less);
}

}  // namespace areomap::dem
