// Far-range interpolation along equi-parallax lines (paper §4.1): beyond ~20 m the stereo points are
// dense in azimuth (one per image column) and sparse in range (one image row, i.e. one parallax level,
// spans a metre or more). The points of each pair are first brought back to image geometry (rectified row
// from the line id, column from the azimuth) and their inverse distance from the ray origin (the
// disparity, up to a slowly varying factor) is replaced by a robust local affine fit over neighbouring rows
// and columns (with a row^2 term where the curvature across rows is significant): a plane is an affine
// disparity field, the disparity noise is uniform, and the regressors are exact, whereas a point's range
// error lies along its ray (a fit of height on range, tried before, regresses on the noisy variable). Each
// point is moved along its own ray to the fitted distance. A cell is then interpolated along the two rows
// that bracket it in range (linearly in azimuth), then linearly in range between them. The result is
// blended with kriging across the seam.
#pragma once

#include "ground/dataset/DemRaster.hpp"
#include "ground/dem/Kriging.hpp"

namespace areomap::dem {

struct EquiParallaxOptions {
  double centre_north_m = 0.0;   // the gimbal centre (site X, Y) the ranges and azimuths are taken from
  double centre_east_m = 0.0;
  double centre_up_m = 0.0;      // elevation of the ray origin (the gimbal centre; the cameras are within
                                 // ~0.2 m of it, a direction error of 0.004 rad at 50 m)
  double seam_m = 20.0;          // kriging inside, equi-parallax outside
  double blend_m = 2.0;          // linear blend over [seam - blend, seam + blend]
  double max_azimuth_gap_rad = 0.02;  // along a line, interpolate only between points this close
  double max_range_gap_m = 15.0;      // between lines, interpolate only across this much range
  int smoothing_half_window = 20;     // affine fit of the inverse distance over +-n columns (0 = none)
  int row_half_window = 3;            // ... and +-n rectified rows of the same pair
  bool quadratic_in_row = true;       // a row^2 term too (3 or more rows): relief curves the disparity
                                      // across rows, and a linear fit would smooth it away
  int robust_iterations = 3;          // Tukey reweightings of that fit (0 = least squares)
};

// The points moved along their rays (through the ray origin) to the robust affine fit of the inverse
// distance over their pair's neighbouring rows and columns (the first step of equiParallaxDem); points
// without a line id or short of seam - blend - max_range_gap are returned unchanged.
std::vector<DemPoint> fitAlongRays(const std::vector<DemPoint>& points, const EquiParallaxOptions& o);

// Equi-parallax DEM of the points with a line id (DemPoint::line >= 0: dense::lineId(pair id, rectified row))
// on `grid`; nodata where no pair of lines brackets a cell or inside seam - blend. Values also in `sigma`
// (the line points' sigmas, interpolated the same way) when it is non-null.
DemGrid equiParallaxDem(const std::vector<DemPoint>& points, const DemGrid& grid, const EquiParallaxOptions& o,
                        DemGrid* sigma = nullptr);

// Blends `far` into `kriged` (same grid): weight of far = 0 inside seam - blend, 1 beyond seam + blend,
// linear between; where one side has no value the other is used. Sigma is blended the same way when
// `far_sigma` is given.
void blendFarRange(KrigingResult& kriged, const DemGrid& far, const DemGrid* far_sigma,
                   const EquiParallaxOptions& o);

// Per cell of `far` (row-major): 0 where blendFarRange with the far range's sigma replaces the kriged value
// and sigma whole (the far range's weight 1 and a far value), 1 elsewhere: the cells whose kriging the
// blend keeps (KrigingOptions::cells).
std::vector<uint8_t> cellsBlendKeeps(const DemGrid& far, const EquiParallaxOptions& o);

}  // namespace areomap::dem
