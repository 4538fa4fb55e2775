// The synthetic Mars surface around the rover: a height field on a square grid of nodes (site frame,
// x north, y east; elevation up = -Z) with multi-octave relief, craters and rocks from Golombek's
// size-frequency model (cumulative fractional area F(D) = k exp(-q(k) D), q = 1.79 + 0.152 / k), an albedo
// grid (dust, bright and dark patches, rock albedo) and procedural fine texture (pebbles) evaluated at
// the surface point. Surfaces are bilinear between nodes; rays are cast exactly against them, accelerated
// by a maximum mip-map. Deterministic from the seed and independent of the thread count.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "ground/dataset/DemRaster.hpp"
#include "ground/sim/SimConfig.hpp"

namespace areomap::sim {

// Expected rocks per square metre with diameter in [d_min, d_max] (Golombek): the number density
// n(D) = -dF/dD / (pi D^2 / 4) = 4 k q exp(-q D) / (pi D^2), integrated numerically in log D.
double golombekRockDensity(double k, double d_min_m, double d_max_m);

class Terrain {
 public:
  // Builds the surface of `config` (half_extent_m, cell_m, relief_m, rock_k, crater density, seed).
  static Terrain build(const SimConfig& config);

  // Elevation (up, metres) at a site point, bilinear; clamped to the grid edge outside.
  double elevation(double x_m, double y_m) const;
  // Upward unit normal (site frame) of the bilinear surface at a site point.
  Eigen::Vector3d normal(double x_m, double y_m) const;
  // Albedo (0..1) at a surface point: the albedo grid times fine texture that fades with range.
  double albedo(double x_m, double y_m) const;
  bool inside(double x_m, double y_m) const;

  // First intersection of origin + t * direction (site frame, t > 0) with the surface inside the grid.
  // False when the ray leaves the grid (or rises above every node) without hitting.
  bool castRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double& t_hit,
               double t_max = std::numeric_limits<double>::infinity()) const;

  // The surface as a DEM of the raster contract: one cell per node, cell centres on the nodes.
  DemGrid dem() const;

  int nodes() const { return n_; }
  double cellM() const { return cell_; }
  double minElevation() const { return h_min_; }
  double maxElevation() const { return h_max_; }
  // Mean elevation of the grid edge: the far plane beyond the grid.
  double farElevation() const { return h_far_; }
  int rockCount() const { return rocks_; }
  int craterCount() const { return craters_; }

 private:
  float node(int ix, int iy) const { return h_[static_cast<std::size_t>(ix) * n_ + iy]; }
  struct GridRay;
  struct Rock;
  static void rasterRock(Terrain& t, const Rock& rock, uint64_t seed, int i0, int i1, int j0, int j1);
  bool intersectCell(int ci, int cj, const GridRay& ray, double ta, double tb, double& t_hit) const;
  void buildMaxMipmap();

  uint64_t seed_ = 0;
  int n_ = 0;         // nodes per side
  double x0_ = 0.0;   // site x (north) of node row 0
  double y0_ = 0.0;   // site y (east) of node column 0
  double cell_ = 1.0;
  double texture_ifov_rad_ = 0.005;  // the finest pixel angle of the cameras: texture octaves fade below it
  std::vector<float> h_;       // [ix * n + iy], elevation up
  std::vector<float> albedo_;  // same layout
  std::vector<std::vector<float>> mip_;  // mip_[L - 1]: max over blocks of 2^L x 2^L cells (L >= 1)
  std::vector<int> mip_size_;
  float h_min_ = 0.0f, h_max_ = 0.0f, h_far_ = 0.0f;
  int rocks_ = 0;
  int craters_ = 0;
};

}  // namespace areomap::sim
