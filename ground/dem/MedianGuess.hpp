// An exact median that starts from the previous one (the equi-parallax fit's reweightings, EquiParallax.cpp).
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace areomap::dem {

// The median (the element of rank n / 2, as std::nth_element leaves it) of a sequence of value sets, per
// iteration index, found from a guess: that iteration's median of the set before (the equi-parallax fit's
// windows of one row's neighbouring points share most of their points, and the medians of their absolute
// residuals differ little). One pass counts the values below a band about the guess and gathers those in
// it; when the rank falls in the band only the band is ordered, else only the side of the band that holds
// it (the whole set when a value is NaN, which none of the three counts takes). The value is the same either
// way (a rank's value does not depend on how it is found); the band's half-width follows the
// misses (doubled after one, narrowed by a tenth after a hit), so the guess changes only the time taken.
// Values >= 0 (the band is relative to the guess); others are right too, on the whole set.
class MedianGuess {
 public:
  static constexpr int kMaxIterations = 8;  // reweightings with a guess of their own (others: no guess)

  double median(const std::vector<double>& values, int iteration) {
    const std::size_t rank = values.size() / 2;
    Guess* g = iteration >= 0 && iteration < kMaxIterations ? &guesses_[iteration] : nullptr;
    if (g != nullptr && g->known) {
      const double lo = g->value * (1.0 - g->half_width), hi = g->value * (1.0 + g->half_width);
      // Without branches on the values (about half of them lie on either side): each value is written to
      // the band's next slot, which only a value inside the band keeps.
      if (band_.size() < values.size() + 1) band_.resize(values.size() + 1);
      double* band = band_.data();
      std::size_t below = 0, above = 0, in_band = 0;
      for (const double v : values) {
        below += v < lo;
        above += v > hi;
        band[in_band] = v;
        in_band +=
            (v >= lo) & (v <= hi);  // NaN is none of the three, and sends the whole set to std::nth_element
      }
      if (below + above + in_band == values.size() && rank >= below && rank < below + in_band) {
        std::nth_element(band, band + (rank - below), band + in_band);
        g->value = band[rank - below];
        g->half_width = std::max(kMinHalfWidth, 0.9 * g->half_width);
        return g->value;
      }
      g->half_width = std::min(kMaxHalfWidth, 2.0 * g->half_width);
      if (below + above + in_band == values.size()) {
        // The rank lies on one side of the band: only that side is ordered.
        const bool low_side = rank < below;
        const std::size_t side_rank = low_side ? rank : rank - below - in_band;
        std::size_t m = 0;
        for (const double v : values) {
          band[m] = v;
          m += low_side ? v < lo : v > hi;
        }
        std::nth_element(band, band + side_rank, band + m);
        g->value = band[side_rank];
        return g->value;
      }
    }
    band_.assign(values.begin(), values.end());
    std::nth_element(band_.begin(), band_.begin() + rank, band_.end());
    if (g != nullptr) {
      g->value = band_[rank];
      g->known = true;
    }
    return band_[rank];
  }

 private:
  static constexpr double kMinHalfWidth = 1.0 / 64, kMaxHalfWidth = 1.0;  // relative to the guess
  struct Guess {
    double value = 0.0;
    double half_width = 0.25;
    bool known = false;
  };
  Guess guesses_[kMaxIterations];
  std::vector<double> band_;
};

}  // namespace areomap::dem
