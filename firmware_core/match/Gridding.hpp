// Gridding (paper §3.4): the final selection of tie points. The image is divided into square cells and each
// cell keeps only its best candidate, so that the ties spread over the image instead of crowding where the
// texture is strongest; the cell size follows the pair's tie budget (selectionGridPx, StereoMatcher.hpp).
// Used for the intra-stereo ties (the best verified match per cell, StereoMatcher) and for a single image's
// points (the strongest interest point per cell, PanoramaMatcher). No heap.
#pragma once

#include <cstdint>

namespace areomap {

struct Gridding {
  int32_t cell_px = 1;
  int32_t cells_x = 0;
  int32_t cells_y = 0;

  // The cells of `cell_px` pixels over a width x height image (the last row and column may be partial).
  Gridding(int32_t cell, int32_t width, int32_t height)
      : cell_px(cell), cells_x((width + cell - 1) / cell), cells_y((height + cell - 1) / cell) {}

  int32_t cells() const { return cells_x * cells_y; }
  // The cell of an integer pixel inside the image.
  int32_t cellOf(int32_t x_px, int32_t y_px) const { return (y_px / cell_px) * cells_x + x_px / cell_px; }

  // cell_best[c] (cells() entries) = the index of the best of `count` candidates in cell c, -1 for none.
  // pixel_of(i, x_px, y_px) gives candidate i's integer pixel and returns false when it does not take part;
  // score_of(i) its score. A later candidate replaces a cell's best only with a strictly higher score.
  template <typename PixelOf, typename ScoreOf>
  void selectBest(int32_t count, PixelOf pixel_of, ScoreOf score_of, int32_t* cell_best) const {
    for (int32_t c = 0; c < cells(); ++c) cell_best[c] = -1;
    for (int32_t i = 0; i < count; ++i) {
      int32_t x = 0, y = 0;
      if (!pixel_of(i, x, y)) continue;
      int32_t& best = cell_best[cellOf(x, y)];
      if (best < 0 || score_of(best) < score_of(i)) best = i;
    }
  }
};

}  // namespace areomap
