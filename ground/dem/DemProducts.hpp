// Writes the DEM products of a kriging run: dem.tif and dem_sigma.tif (DESIGN.md "Rasters": float32,
// north-up, pixel-is-area, nodata set) through ground/dataset's writeDemGeoTiff, then adds a local
// engineering CRS in metres (site frame: east = +Y, north = +X) and metadata naming the site and sols.
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

// Writes `dir`/dem.tif and `dir`/dem_sigma.tif. Throws (DatasetError / std::runtime_error) naming the file.
void writeDemProducts(const std::string& dir, const KrigingResult& result, const DemMetadata& metadata);

// Adds the CRS and metadata to an existing GeoTIFF (used for dem.tif, dem_sigma.tif; also usable for
// truth/dem.tif and ortho.tif).
void tagSiteRaster(const std::string& path, const DemMetadata& metadata, const std::string& values);

}  // namespace areomap::dem
