// Verification by parallax consistency (paper §3.4, §4.1): the parallax of the matches, plotted against
// their row, follows a smooth curve (for terrain seen from a mast, inverse range is close to linear in the
// row). A quadratic p(row) is fitted by least squares with iterative trimming; a match departing from it by
// more than max(min_tolerance_px, k * 1.4826 * MAD) is rejected. The fitted curve and the spread are the
// "parallax ranges along the rows" that the dense matcher reuses.
#pragma once

#include <cstdint>

#include "firmware_core/base/Capacities.hpp"
#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/base/Status.hpp"

namespace areomap {

struct ParallaxCurve {
  Vec3 coefficients = Vec3::Zero();  // p = c0 + c1 t + c2 t^2, t = (row - row_centre) / row_scale
  double row_centre = 0.0;
  double row_scale = 1.0;
  double sigma_px = 0.0;  // robust spread of the inliers (1.4826 MAD)
  int32_t inliers = 0;
  double evaluate(double row) const {
    const double t = (row - row_centre) / row_scale;
    return coefficients[0] + t * (coefficients[1] + t * coefficients[2]);
  }
};

struct ParallaxParams {
  double min_tolerance_px = 6.0;
  double sigma_factor = 4.0;
  int32_t min_points = 6;  // fewer: kNoTexture (nothing to verify against)
};

// rows/parallax: `count` values; `inlier` receives the verdict per value. `scratch` holds `count` doubles.
[[nodiscard]] Status fitParallaxCurve(const float* rows, const float* parallax_px, int32_t count,
                                      const ParallaxParams& params, double row_centre, double row_scale,
                                      bool* inlier, double* scratch, ParallaxCurve& curve);

// Median of the first `count` values of `values` (reordered in place; bounded selection, no heap).
double medianInPlace(double* values, int32_t count);

}  // namespace areomap
