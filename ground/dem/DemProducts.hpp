// Writes the DEM products of a kriging run: dem.tif and dem_sigma.tif (DESIGN.md "Rasters": float32,
// north-up, pixel-is-area, nodata set) and dem_seen.tif (8-bit, the same grid: 0 unseen = nodata,
// 1 interpolated, 2 measured; DemSeen.hpp) through ground/raster, atomically (temporary name, read back,
// rename), with a local engineering CRS in metres (site frame: east = +Y, north = +X) and metadata naming
// the site and sols.
#pragma once

#include <string>
#include <vector>

#include "ground/dem/DemSeen.hpp"
#include "ground/dem/Kriging.hpp"
#include "ground/raster/RasterFiles.hpp"

namespace areomap::dem {

// Site, sols and variogram of the DEM rasters (ground/raster's tags).
using DemMetadata = raster::SiteTags;

// Writes `dir`/<stem>.tif, `dir`/<stem>_sigma.tif and, with `seen` (its classes on the DEM's grid),
// `dir`/<stem>_seen.tif (dem.tif, dem_sigma.tif, dem_seen.tif by default) atomically: each under a
// temporary name in `dir`, read back and compared, then renamed into place (the classes, the sigma, the
// DEM right after). Throws cli::InputError naming the product on failure (full disk, folder not
// writable); no temporary is left behind and a previous product stays as it was.
void writeDemProducts(const std::string& dir, const KrigingResult& result, const DemMetadata& metadata,
                      const std::string& stem = "dem", const DemSeen* seen = nullptr);

}  // namespace areomap::dem
