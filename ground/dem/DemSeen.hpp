// Seen, interpolated, unseen (dem_seen.tif, docs/products.md "Seen and unseen cells"). Every cell of a
// made DEM is one of:
//   measured (2): points of the cloud lie in it;
//   interpolated (1): no point in it, kriged from points around it within the kriging's reach, and some
//     camera of the panorama sees it: it lies inside that camera's image and no measured terrain between
//     them hides it;
//   unseen (0): beyond the reach (nodata), or no camera sees it (the shadow of nearer terrain behind a rock,
//     ground outside every image): the DEM leaves it empty.
// An interpolated cell is tested at its estimate; only measured cells hide, each lowered by two of its
// sigmas (noise does not hide the cells behind it); the horizons are ground/dem Viewshed's.
// Limit: behind a rock the kriging spreads the rock's top along the lines of sight that graze it, so the
// estimate there lies on or above those lines and the test at the estimate cannot tell it from seen
// ground; testing lower (the estimate less its sigmas) hides seen ground behind its noisy neighbours
// first. Such cells stay interpolated (docs/products.md "Seen and unseen cells" gives the figures).
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
};

// Per cell of `grid`: 1 where a point of `bins` (BinnedCloud::points: one per cell) lies in it.
std::vector<uint8_t> measuredCells(const std::vector<DemPoint>& bins, const DemGrid& grid);

// Classifies the cells of `dem` (above) and empties the unseen ones (elevation and sigma nodata).
// `cameras`: every image of the panorama, with its size; none: interpolated cells are not tested.
DemSeen classifyDemCells(KrigingResult& dem, const std::vector<uint8_t>& measured,
                         const std::vector<CameraModel>& cameras);

}  // namespace areomap::dem
