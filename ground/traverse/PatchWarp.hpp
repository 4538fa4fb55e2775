// The offsets in image J of a template's grid samples through a PatchSurface (WarpedPatchMatcher.hpp):
// each sample's ray cast through the surface, or, where the surface is smooth over the patch, the casts on a
// coarse lattice of the template interpolated between.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "ground/traverse/WarpedPatchMatcher.hpp"

namespace areomap::traverse {

// For grid sample k = (v + h) (2h + 1) + (u + h) of the template around i_px (I offset mi (u, v)), its offset
// in J from the centre's place `j_centre_px` (the surface's map of i_px): surface.map of the sample minus
// j_centre_px, or mj (u, v) where the surface does not map it.
//
// With tolerance_px > 0 the casts are made on lattices of (n + 1)^2 nodes over the template, n = 2, 4, 8,
// ...: the nodes a lattice adds are compared with the previous lattice's bilinear interpolation, and where
// the largest difference is within tolerance_px the offsets are interpolated from the lattice that found it
// (the difference bounds the coarser lattice's error; a smooth surface's error falls with the square of the
// node spacing, so the finer one's is about a quarter of it). A surface with relief, an edge or a sample it
// cannot map within the patch makes the lattices disagree or fail, and then every sample is cast.
// The number of casts made goes into `casts` when given.
void surfaceOffsets(const PatchSurface& surface, const Eigen::Vector2d& i_px,
                    const Eigen::Vector2d& j_centre_px, const Eigen::Matrix2d& mi, const Eigen::Matrix2d& mj,
                    int h, double tolerance_px, std::vector<Eigen::Vector2d>& off_j, int* casts = nullptr);

}  // namespace areomap::traverse
