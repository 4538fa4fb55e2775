// The cameras' part of the DEM sigma (ground/dem/SharedHeightError.hpp) from the products' inputs: each
// pair's height gradient with respect to its 12 EO unknowns, by the first-order error propagation of the
// two-ray intersection (the point X minimises the ray residuals r(X, e): dX/de = -(A^T A)^-1 A^T B with A =
// dr/dX, B = dr/de of both cameras, Photogrammetric.hpp's collinearity; the height is -Z).
#pragma once

#include <optional>

#include "ground/dem/SharedHeightError.hpp"
#include "ground/products/Products.hpp"

namespace areomap::products {

// d(height up) / d[left dC, delta, right dC, delta] of a point (site frame) seen by two cameras; false when
// it is behind either or their rays are parallel there.
bool heightGradient(const NetImage& left, const NetImage& right, const Vec3& point_site_m, double* g);

// Absent when the inputs carry no EO uncertainty (or no pair has a block).
std::optional<dem::SharedHeightError> cameraHeightError(const ProductInputs& in);

}  // namespace areomap::products
