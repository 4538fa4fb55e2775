// Seen, interpolated, unseen (dem_seen.tif, docs/products.md "Seen and unseen cells"). Every cell of a
// made DEM is one of:
//   measured (2): points of the cloud lie in it, and some camera whose image holds it does not show a
//     nearer measured surface all about its pixel (free space: a camera cannot have measured ground behind
//     what it images; such a cell holds points carried along their rays beyond the surface their pixels
//     image, e.g. a rock's face matched at the ground's disparity, and is unseen);
//   interpolated (1): no point in it, kriged from points around it within the kriging's reach, and some
//     camera of the panorama sees it: it lies inside that camera's image and no measured terrain between
//     them hides it;
//   unseen (0): beyond the reach (nodata), or no camera sees it (the shadow of nearer terrain behind a rock,
//     ground outside every image): the DEM leaves it empty.
// Whether a camera sees an interpolated cell is read from a depth buffer of the measured cells in that
// camera's image (a z-buffer over bins of a few pixels), not from the estimate's height: behind a rock the
// kriging spreads the rock's top along the lines of sight that graze it, so a visibility test at the
// estimate cannot tell shadow from seen ground, while the image shows a jump in depth from the rock's top
// to the ground beyond, over the cell. The cost is one projection per measured cell and per tested cell
// in each camera whose image holds it (O(cells x cameras)).
// Limit: the classes are the measured data's; a cell that holds points is measured even where the true
// ground at its centre lies a millimetre in the shadow of a pebble, and a shadow shorter than the spacing
// of the ground's samples (a few pixels at the grazing angle) cannot show as a jump (docs/products.md
// "Seen and unseen cells" gives the figures).
#pragma once

#include <cstdint>
#include <vector>

#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dem/Kriging.hpp"

namespace areomap::dem {

inline constexpr uint8_t kCellUnseen = 0;
inline constexpr uint8_t kCellInterpolated = 1;
inline constexpr uint8_t kCellMeasured = 2;

struct DemSeen {
  std::vector<uint8_t> classes;  // per cell of the DEM's grid, row-major
  long long measured = 0, interpolated = 0;
  long long emptied = 0;  // kriged cells left empty as unseen
  long long hidden = 0;   // of them, cells holding points that every camera shows behind nearer ones
};

// Per cell of `grid`: 1 where a point of `bins` (BinnedCloud::points: one per cell) lies in it.
std::vector<uint8_t> measuredCells(const std::vector<DemPoint>& bins, const DemGrid& grid);

// Classifies the cells of `dem` (above) and empties the unseen ones (elevation and sigma nodata).
// `cameras`: every image of the panorama, with its size; none: interpolated cells are not tested.
DemSeen classifyDemCells(KrigingResult& dem, const std::vector<uint8_t>& measured,
                         const std::vector<CameraModel>& cameras);

}  // namespace areomap::dem
