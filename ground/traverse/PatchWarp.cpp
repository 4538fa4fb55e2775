#include "ground/traverse/PatchWarp.hpp"

#include <algorithm>
#include <cmath>

namespace areomap::traverse {

namespace {

// A lattice of (n + 1)^2 nodes over the template's grid [-h, h]^2, row-major, and the J offsets cast there.
struct Lattice {
  int n = 0;
  double h = 0.0;
  std::vector<Eigen::Vector2d> off;

  Eigen::Vector2d node(int i, int j) const {
    return Eigen::Vector2d(-h + 2.0 * h * i / n, -h + 2.0 * h * j / n);
  }
  const Eigen::Vector2d& at(int i, int j) const { return off[static_cast<std::size_t>(j) * (n + 1) + i]; }

  // The bilinear interpolation of the nodes' offsets at grid position g.
  Eigen::Vector2d interpolate(const Eigen::Vector2d& g) const {
    const double fx = (g.x() + h) * n / (2.0 * h), fy = (g.y() + h) * n / (2.0 * h);
    const int i = std::clamp(static_cast<int>(std::floor(fx)), 0, n - 1);
    const int j = std::clamp(static_cast<int>(std::floor(fy)), 0, n - 1);
    const double tx = fx - i, ty = fy - j;
    return (1 - tx) * (1 - ty) * at(i, j) + tx * (1 - ty) * at(i + 1, j) + (1 - tx) * ty * at(i, j + 1) +
           tx * ty * at(i + 1, j + 1);
  }
};

}  // namespace

void surfaceOffsets(const PatchSurface& surface, const Eigen::Vector2d& i_px,
                    const Eigen::Vector2d& j_centre_px, const Eigen::Matrix2d& mi, const Eigen::Matrix2d& mj,
                    int h, double tolerance_px, std::vector<Eigen::Vector2d>& off_j, int* casts) {
  const int side = 2 * h + 1;
  int made = 0;
  // The offset of grid position g; false where the surface does not map it (the affine offset then).
  auto cast = [&](const Eigen::Vector2d& g, Eigen::Vector2d& off) {
    ++made;
    Eigen::Vector2d pj;
    const bool mapped = surface.map(i_px + mi * g, pj);
    off = mapped ? Eigen::Vector2d(pj - j_centre_px) : Eigen::Vector2d(mj * g);
    return mapped;
  };
  auto grid = [&](int k) { return Eigen::Vector2d(k % side - h, k / side - h); };
  bool interpolated = false;
  if (tolerance_px > 0.0 && h > 0) {
    Lattice coarse{2, static_cast<double>(h), std::vector<Eigen::Vector2d>(9)};
    bool mapped = true;
    for (int j = 0; j <= 2 && mapped; ++j)
      for (int i = 0; i <= 2 && mapped; ++i) mapped = cast(coarse.node(i, j), coarse.off[j * 3 + i]);
    // Each finer lattice while it has well under the template's samples (else casting them all is as cheap).
    for (int n = 4; mapped && 2 * (n + 1) * (n + 1) <= side * side; n *= 2) {
      Lattice fine{n, static_cast<double>(h),
                   std::vector<Eigen::Vector2d>(static_cast<std::size_t>(n + 1) * (n + 1))};
      double worst = 0.0;
      for (int j = 0; j <= n && mapped; ++j) {
        for (int i = 0; i <= n && mapped; ++i) {
          Eigen::Vector2d& off = fine.off[static_cast<std::size_t>(j) * (n + 1) + i];
          if (i % 2 == 0 && j % 2 == 0) {
            off = coarse.at(i / 2, j / 2);
            continue;
          }
          mapped = cast(fine.node(i, j), off);
          worst = std::max(worst, (off - coarse.interpolate(fine.node(i, j))).norm());
        }
      }
      if (!mapped) break;
      coarse = std::move(fine);
      if (worst <= tolerance_px) {
        for (int k = 0; k < side * side; ++k)
          off_j[static_cast<std::size_t>(k)] = coarse.interpolate(grid(k));
        interpolated = true;
        break;
      }
    }
  }
  if (!interpolated) {
    for (int k = 0; k < side * side; ++k) (void)cast(grid(k), off_j[static_cast<std::size_t>(k)]);
  }
  if (casts != nullptr) *casts = made;
}

}  // namespace areomap::traverse
