// The synthetic Mars surface around the rover: a height field on a square grid of nodes (site frame,
// x north, y east; elevation up = -Z) with multi-octave relief, craters and rocks from Golombek's
// size-frequency model (cumulative fractional area F(D) = k exp(-q(k) D), q = 1.79 + 0.152 / k), an albedo
// grid (dust, bright and dark patches, rock albedo) and procedural fine texture (pebbles) evaluated at
// the surface point. Surfaces are bilinear between nodes; rays are cast exactly against them, accelerated
// by a maximum mip-map. Deterministic from the seed and independent of the thread count.
#pragma once

#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "ground/dataset/DemRaster.hpp"
#include "ground/dataset/Traverse.hpp"
#include "ground/sim/SimConfig.hpp"

namespace areomap::sim {

// Expected rocks per square metre with diameter in [d_min, d_max] (Golombek): the number density
// n(D) = -dF/dD / (pi D^2 / 4) = 4 k q exp(-q D) / (pi D^2), integrated numerically in log D.
double golombekRockDensity(double k, double d_min_m, double d_max_m);

class Terrain {
 public:
  // Half-side (m) of the square the terrain covers around its centre for `config`: the fine grid, extended
  // by the coarse outer grid to at least kMinCoverHalfM (or config.cover_half_extent_m when set).
  static constexpr double kMinCoverHalfM = 50.0;
  static constexpr double kCoarseCellM = 0.1;
  static double coverHalfExtentM(const SimConfig& config);

  // Builds the surface of `config` (half_extent_m, cell_m, relief_m, rock_k, crater density, seed): a fine
  // grid of cell_m over +-half_extent_m (rocks, craters, all relief octaves) and, when that is under
  // +-kMinCoverHalfM, a coarse outer grid (kCoarseCellM) out to +-kMinCoverHalfM that continues the same
  // relief function (same octaves at the coarse nodes, craters, no rocks). The fine grid wins where it is.
  static Terrain build(const SimConfig& config);

  // Elevation (up, metres) at a site point, bilinear; clamped to the grid edge outside.
  double elevation(double x_m, double y_m) const;
  // Upward unit normal (site frame) of the bilinear surface at a site point.
  Eigen::Vector3d normal(double x_m, double y_m) const;
  // Albedo (0..1) at a surface point: the albedo grid times fine texture that fades with range.
  double albedo(double x_m, double y_m) const;
  // Inside the terrain (fine or coarse grid).
  bool inside(double x_m, double y_m) const;
  // Half-side (m) of the square covered around the terrain's centre (the smallest of the four sides).
  double halfExtentM() const;
  // Distance (m) in x, y from a point to the nearest rover position of the configuration.
  double rangeToNearestRover(double x_m, double y_m) const;

  // First intersection of origin + t * direction (site frame, t > 0) with the surface inside the terrain.
  // False when the ray leaves the terrain (or rises above every node) without hitting.
  bool castRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double& t_hit,
               double t_max = std::numeric_limits<double>::infinity()) const;

  // The surface as a DEM of the raster contract, at the fine cell size over the whole covered square:
  // the fine nodes where the fine grid is, the coarse surface (bilinear) sampled beyond. Cell centres
  // on the fine nodes.
  DemGrid dem() const;
  // The surface as a DEM in another levelled frame F placed by `terrain_from_frame` (p_terrain =
  // Rz(heading) p_F + position): a square of half side `half_extent_m` about F's (x, y) = `centre_m`, cell
  // `cell_m`, elevations up in F (the terrain's minus the frame origin's height), sampled bilinearly at the
  // cell centres; nodata beyond the terrain.
  DemGrid demInFrame(const SitePose& terrain_from_frame, const Eigen::Vector2d& centre_m,
                     double half_extent_m, double cell_m) const;

  int nodes() const { return fine_.n; }
  int coarseNodes() const { return coarse_.n; }
  double cellM() const { return fine_.cell; }
  double minElevation() const { return h_min_; }
  double maxElevation() const { return h_max_; }
  // Mean elevation of the terrain's edge: the far plane beyond it.
  double farElevation() const { return h_far_; }
  int rockCount() const { return rocks_; }
  int craterCount() const { return craters_; }

 private:
  struct GridRay;
  struct Rock;
  struct Crater;
  struct Relief;
  // One square height field of nodes with its albedo and maximum mip-map.
  struct Grid {
    int n = 0;        // nodes per side (0: absent)
    double x0 = 0.0;  // site x (north) of node row 0
    double y0 = 0.0;  // site y (east) of node column 0
    double cell = 1.0;
    std::vector<float> h;                 // [ix * n + iy], elevation up
    std::vector<float> albedo;            // same layout
    std::vector<std::vector<float>> mip;  // mip[L - 1]: max over blocks of 2^L x 2^L cells (L >= 1)
    std::vector<int> mip_size;
    float h_min = 0.0f, h_max = 0.0f;
    float node(int ix, int iy) const { return h[static_cast<std::size_t>(ix) * n + iy]; }
    bool inside(double x_m, double y_m) const;
    double elevation(double x_m, double y_m) const;
    Eigen::Vector3d normal(double x_m, double y_m) const;
    double albedoAt(double x_m, double y_m) const;
    void buildMaxMipmap();
    bool intersectCell(int ci, int cj, const GridRay& ray, double ta, double tb, double& t_hit) const;
    // First hit with t in [t_lo, t_hi) inside this grid.
    bool castRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_lo, double t_hi,
                 double& t_hit) const;
    // The t interval of the ray over the grid square (false when it misses it).
    bool clip(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double& ta, double& tb) const;
  };
  // The steps of build(), in the order it runs them (Terrain.cpp).
  void layOutGrids(const SimConfig& config);
  Relief drawRelief(const SimConfig& config, std::mt19937_64& rng) const;
  static void fillRelief(Grid& g, const Relief& relief, int threads);
  static bool addCrater(Grid& g, const Crater& crater, int threads);
  void addCraters(const SimConfig& config, std::mt19937_64& rng);
  void addOuterCraters(const SimConfig& config);
  std::vector<Rock> drawRocks(const SimConfig& config) const;
  void addRocks(const SimConfig& config);
  static void rasterRock(Grid& g, const Rock& rock, uint64_t seed, int i0, int i1, int j0, int j1);
  void finishElevations();
  const Grid& gridAt(double x_m, double y_m) const {
    return coarse_.n > 0 && !fine_.inside(x_m, y_m) ? coarse_ : fine_;
  }

  uint64_t seed_ = 0;
  Eigen::Vector2d centre_ = Eigen::Vector2d::Zero();
  std::vector<Eigen::Vector2d> rovers_;  // at least one (the origin by default)
  double texture_ifov_rad_ = 0.005;  // the finest pixel angle of the cameras: texture octaves fade below it
  Grid fine_;
  Grid coarse_;
  float h_min_ = 0.0f, h_max_ = 0.0f, h_far_ = 0.0f;
  int rocks_ = 0;
  int craters_ = 0;
};

}  // namespace areomap::sim
