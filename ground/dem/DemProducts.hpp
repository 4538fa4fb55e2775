// Writes the DEM products of a kriging run: dem.tif and dem_sigma.tif (DESIGN.md "Rasters": float32,
// north-up, pixel-is-area, nodata set) through ground/dataset's writeDemGeoTiff, atomically (temporary
// name, read back, rename), with a local engineering CRS in metres (site frame: east = +Y, north = +X)
// and metadata naming the site and sols.
#pragma once

#include <string>
#include <vector>

#include "ground/dem/Kriging.hpp"

namespace areomap::dem {

struct DemMetadata {
  std::string site;       // e.g. the panorama name
  std::vector<int> sols;  // sols of the images that made the DEM
  std::string variogram;  // filled by writeDemProducts from the result
};

// The local engineering CRS (WKT1 LOCAL_CS) of the site frame.
std::string siteCrsWkt(const std::string& site);

// Writes `dir`/<stem>.tif and `dir`/<stem>_sigma.tif (dem.tif, dem_sigma.tif by default) atomically: each
// under a temporary name in `dir`, read back and compared, then renamed into place (the sigma first, the
// DEM right after). Throws cli::InputError naming the product on failure (full disk, folder not
// writable); no temporary is left behind and a previous product stays as it was.
void writeDemProducts(const std::string& dir, const KrigingResult& result, const DemMetadata& metadata,
                      const std::string& stem = "dem");

// Reads band 1 of the raster at `path` and throws std::runtime_error naming it unless it is `cols` x `rows`
// and byte-identical to `data` (float32 when `float32`, else 8-bit): the proof that a GDAL write is complete
// (GDAL reports a failed write at close, where the C API does not return it to us).
void verifyRaster(const std::string& path, int cols, int rows, bool float32, const void* data);

// Adds the CRS and metadata to an existing GeoTIFF (used for dem.tif, dem_sigma.tif; also usable for
// truth/dem.tif and ortho.tif).
void tagSiteRaster(const std::string& path, const DemMetadata& metadata, const std::string& values);

}  // namespace areomap::dem
