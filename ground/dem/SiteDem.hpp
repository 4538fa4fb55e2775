// The site's DEMs from its dense cloud (paper §4.1, DESIGN.md "Products"): the grid around the points
// within max_range_m (cell automatic or given), the cloud binned to it, ordinary kriging of the bins with
// the matcher's error correlation (the DEM sigma), equi-parallax interpolation beyond the seam blended
// into it, cells beyond max_range_m emptied; and, when that grid is coarser than near_cell_m, the finer
// near-rover DEM (the points within near_range_m binned and kriged again at near_cell_m). Each DEM's cells
// are then classified measured, interpolated or unseen, and the unseen ones emptied (DemSeen.hpp). Writing
// the rasters is the caller's (DemProducts.hpp).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "firmware_core/base/EigenTypes.hpp"
#include "firmware_core/camera/CameraModel.hpp"
#include "ground/dem/DemSeen.hpp"
#include "ground/dem/Kriging.hpp"
#include "ground/dem/PackedCloud.hpp"

namespace areomap::dem {

struct SiteDemOptions {
  Vec3 gimbal_site_m = Vec3::Zero();  // ranges are taken from it (site frame, Z down)
  double cell_m = -1.0;               // dem.tif cell (-1: autoDemCell of the cloud's extent)
  double near_cell_m = 0.02;          // <= 0: no near-rover DEM
  double near_range_m = 10.0;
  double max_range_m = 60.0;    // cells farther from the gimbal centre stay nodata
  double seam_m = 20.0;         // kriging inside, equi-parallax interpolation outside
  double correlation_px = 0.0;  // the matcher's error correlation length (pixels, exp(-lag / L))
  // The cameras' error, shared by each pair's points and correlated between pairs (SharedHeightError.hpp;
  // nullptr: the sigma leaves it out).
  const SharedHeightError* shared_error = nullptr;
  // Every image of the panorama (its size set): what they see decides which cells are seen (DemSeen.hpp);
  // none: interpolated cells are kept untested.
  std::vector<CameraModel> cameras;
};

struct SiteDem {
  std::optional<KrigingResult> dem;   // absent when it could not be made (see warnings)
  std::optional<KrigingResult> near;  // the near-rover DEM, when made
  DemSeen dem_seen, near_seen;        // their cells' classes (dem_seen.tif, dem_near_seen.tif)
  long long points_binned = 0;        // the cloud's points in dem.tif's bins (every one: kriged or support)
  std::vector<std::string> warnings;  // also printed (cli::warn) when they arise
};

// The dem.tif cell for a cloud `extent_m` wide: 2 cm up to 40 m, then the next of 2.5, 5, 10, 20, 25, 50 cm,
// 1 m for about 2000 cells across.
double autoDemCell(double extent_m);

// Makes both DEMs from `points` (taken over: freed before any kriging). Progress lines on stderr.
SiteDem makeSiteDem(PackedCloud points, const SiteDemOptions& options);

}  // namespace areomap::dem
