// Far-range interpolation along equi-parallax lines (paper §4.1): beyond ~20 m the stereo points are
// dense in azimuth (one per image column) and sparse in range (one image row, i.e. one parallax level,
// spans a metre or more). Each rectified image row of a pair is an equi-parallax line; a cell is
// interpolated along the two lines that bracket it in range (linearly in azimuth along each line, after a
// short moving average), then linearly in range between them. The result is blended with kriging across
// the seam.
#pragma once

#include "ground/dataset/DemRaster.hpp"
#include "ground/dem/Kriging.hpp"

namespace areomap::dem {

struct EquiParallaxOptions {
  double centre_north_m = 0.0;   // the gimbal centre (site X, Y) the ranges and azimuths are taken from
  double centre_east_m = 0.0;
  double seam_m = 20.0;          // kriging inside, equi-parallax outside
  double blend_m = 2.0;          // linear blend over [seam - blend, seam + blend]
  double max_azimuth_gap_rad = 0.02;  // along a line, interpolate only between points this close
  double max_range_gap_m = 15.0;      // between lines, interpolate only across this much range
  int smoothing_half_window = 20;     // moving average of +-n points along a line (0 = none); 20 beat 3
                                      // and 10 on a rendered navcam scene (BENCHMARKS.md, far range)
};

// Equi-parallax DEM of the points with a line id (DemPoint::line >= 0) on `grid`; nodata where no pair of
// lines brackets a cell or inside seam - blend. Values also in `sigma` (the line points' sigmas,
// interpolated the same way) when it is non-null.
DemGrid equiParallaxDem(const std::vector<DemPoint>& points, const DemGrid& grid, const EquiParallaxOptions& o,
                        DemGrid* sigma = nullptr);

// Blends `far` into `kriged` (same grid): weight of far = 0 inside seam - blend, 1 beyond seam + blend,
// linear between; where one side has no value the other is used. Sigma is blended the same way when
// `far_sigma` is given.
void blendFarRange(KrigingResult& kriged, const DemGrid& far, const DemGrid* far_sigma,
                   const EquiParallaxOptions& o);

}  // namespace areomap::dem
