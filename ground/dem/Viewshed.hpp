// What nearer terrain hides from a viewpoint, on a DEM grid (ground/dataset DemGrid: columns east = site +Y,
// rows south, elevation up = -Z): for every cell the lowest elevation at which a point there clears the
// terrain between it and the eye. A point (north, east, up) is hidden when up < horizon of its cell.
//
// One sweep over the grid in square rings about the eye (the "XDraw" viewshed): a cell's horizon is the
// steepest line of sight over the cells before it, from the two cells of the next inner ring that bracket
// its ray, so the whole grid costs O(cells) instead of one ray march per cell. Nodata cells hide nothing
// and pass the lines of sight behind them on. `widen`: the steeper of the two, which widens a shadow by up
// to a cell at its edges but never halves a thin occluder away (an image then never paints a cell it may
// not see); else linear between them (the shadow's edge to a fraction of a cell, a thin occluder weakened).
// A ray march (products::terrainHides, the products tests' castRay) is the check.
//
// Whether an image holds a point (imageSees) is beside it: the products ask both of each camera.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dataset/DemRaster.hpp"

namespace areomap::dem {

// Per cell of `terrain` (row-major, its size), the horizon elevation (up, metres) seen from `eye` (site
// frame, Z down); -infinity where nothing lies between. The eye may lie outside the grid.
void horizonFrom(const DemGrid& terrain, const Vec3& eye_site, std::vector<float>& horizon_up_m, bool widen);

// A block of a grid's cells: columns col0 .. col0 + cols - 1, rows row0 .. row0 + rows - 1.
struct GridWindow {
  int col0 = 0, row0 = 0, cols = 0, rows = 0;
  std::size_t at(int col, int row) const {
    return static_cast<std::size_t>(row - row0) * static_cast<std::size_t>(cols) +
           static_cast<std::size_t>(col - col0);
  }
  bool holds(int col, int row) const {
    return col >= col0 && row >= row0 && col < col0 + cols && row < row0 + rows;
  }
  // Whether the block of columns c0 .. c1 and rows r0 .. r1 has a cell in the window.
  bool meets(int c0, int c1, int r0, int r1) const {
    return c1 >= col0 && r1 >= row0 && c0 < col0 + cols && r0 < row0 + rows;
  }
};

// horizonFrom over the cells of `window` only (horizon_up_m: window.cols x window.rows, row-major; the
// window's cells beyond the grid -infinity): the same values as the whole grid's at those cells. A cell's
// horizon depends only on the cells between it and the eye, so the sweep covers the box about the window
// and the eye's cell, not the whole grid.
void horizonFrom(const DemGrid& terrain, const Vec3& eye_site, const GridWindow& window,
                 std::vector<float>& horizon_up_m, bool widen);

// The horizons held at once by forEachHorizon (made or in use, one per thread at most): a few windows of
// a navcam truth DEM (5001^2 cells), well under the ground pass's peak, which the dense stage (the whole
// cloud beside the pairs in matching) sets before any horizon is made.
inline constexpr std::size_t kMaxHorizonBytes = std::size_t{256} << 20;

// The horizon from each of `eyes` over its window (horizonFrom over windows[k]), made on threads (as many
// at once as kMaxHorizonBytes holds) and handed to use(k, horizon) in the eyes' order, one call at a time:
// the same calls as a loop over the eyes. `use` may run on any of the threads.
void forEachHorizon(const DemGrid& terrain, const std::vector<Vec3>& eyes,
                    const std::vector<GridWindow>& windows, bool widen,
                    const std::function<void(std::size_t, const std::vector<float>&)>& use);

// A camera's image bounds as a cone about its axis, for a quick rejection before the projection.
struct ImageCone {
  Vec3 axis = Vec3::Zero();
  double min_cos = 2.0;  // cosine of the widest off-axis angle of the image's corners and edge midpoints
  double px_per_rad = 0.0;  // the larger focal length, pixels
};
ImageCone imageCone(const CameraModel& model);

// The point `x` (site frame) lies inside the image of `model` (width x height pixels) and the pixel it
// projects to really images it: that pixel's own ray passes within half a pixel of it (the CAHVOR/CAHVORE
// distortion folds points far beyond the field into the image). `cone` from imageCone(model).
bool imageSees(const CameraModel& model, const ImageCone& cone, const Vec3& x);

}  // namespace areomap::dem
