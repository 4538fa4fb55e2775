// The coarse DEM of one stereo pair (paper §3.4, the onboard DEM): the verified intra-stereo ties are
// triangulated with the a-priori models and their elevations averaged on a fixed grid of
// kCoarseDemCells^2 cells of kCoarseDemCellM around the pair; empty cells are filled from their neighbours
// (at most kMaxCoarseDemFillPasses passes). It predicts where a point seen in this pair appears in a
// neighbouring pair: the ray of the pixel is intersected with the surface and the point projected.
// Site frame: X north, Y east, Z down; the grid's rows run along X, its columns along Y; values are Z.
#pragma once

#include <cstdint>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/Status.hpp"

namespace areomap {

class CoarseDem {
 public:
  // Starts an empty grid centred on `centre_m` (X, Y; Z is ignored).
  void reset(const Vec3& centre_m);
  // Accumulates a triangulated point; false (and counted) when it lies outside the grid.
  bool addPoint(const Vec3& point_m);
  // Means per cell, then hole filling. Returns the number of cells with a value.
  int32_t finish();

  // Bilinear elevation (Z, site frame) at (x, y); false outside the grid or near empty cells.
  bool elevationAt(double x_m, double y_m, double& z_m) const;
  // First intersection of a ray (origin, unit direction) with the surface, marching in half-cell steps.
  // kDegenerate when the ray leaves the grid without meeting it.
  [[nodiscard]] Status intersectRay(const Vec3& origin, const Vec3& direction, Vec3& point) const;

  int32_t pointCount() const { return point_count_; }
  int32_t outsideCount() const { return outside_count_; }
  int32_t measuredCells() const { return measured_cells_; }
  Vec3 origin() const { return origin_m_; }  // outer corner of cell (0, 0)
  bool cellValue(int32_t row, int32_t col, double& z_m) const;
  static constexpr int32_t cells() { return kCoarseDemCells; }
  static constexpr double cellSize() { return kCoarseDemCellM; }

 private:
  Vec3 origin_m_ = Vec3::Zero();
  float sum_z_[kCoarseDemCells][kCoarseDemCells] = {};
  uint16_t count_[kCoarseDemCells][kCoarseDemCells] = {};
  float z_[kCoarseDemCells][kCoarseDemCells] = {};
  bool valid_[kCoarseDemCells][kCoarseDemCells] = {};
  bool filled_[kCoarseDemCells][kCoarseDemCells] = {};
  int32_t point_count_ = 0;
  int32_t outside_count_ = 0;
  int32_t measured_cells_ = 0;
};

}  // namespace areomap
