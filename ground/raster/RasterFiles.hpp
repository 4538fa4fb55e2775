// Every raster file the ground writes, in one place (DESIGN.md "Rasters"):
//  - GeoTIFF, one band, north-up, pixel-is-area, geotransform (east0, cell, 0, north0, 0, -cell) with east =
//    site +Y and north = site +X in site metres: float32 (DEFLATE, predictor 3, tiled, the site frame's
//    LOCAL_CS; dem.tif, dem_sigma.tif, dem_near*.tif, truth/dem.tif) and 8-bit (ortho.tif);
//  - the site tags (CRS naming the site, AREOMAP_SITE / _SOLS / _FRAME / _VALUES / _VARIOGRAM) and the
//    read-back that proves a GDAL write complete;
//  - the reading of a float32 GeoTIFF's band 1 with its geometry (DEM-like rasters,
//  ground/dataset/DemRaster);
//  - PNG (previews, overlays, the simulator's and the stream collector's images), encoded in memory and
//    written whole or not at all (cli::writeFileAtomic).
// Errors are cli::InputError naming the file.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace areomap::raster {

struct Geometry {
  int cols = 0;
  int rows = 0;
  double east0_m = 0.0;   // west edge of the first column (site +Y)
  double north0_m = 0.0;  // north edge of the first row (site +X)
  double cell_m = 0.0;
};

// Float32 GeoTIFF of `values` (rows x cols, row-major); the parent folder is created.
void writeGeoTiff(const std::string& path, const Geometry& g, const float* values, float nodata);
// 8-bit GeoTIFF of `values` (rows x cols, row-major).
void writeGeoTiff(const std::string& path, const Geometry& g, const uint8_t* values, uint8_t nodata);

struct SiteTags {
  std::string site;       // e.g. the panorama name
  std::vector<int> sols;  // sols of the images that made the raster
  std::string variogram;  // the DEM's variogram, when it has one
};

// The local engineering CRS (WKT1 LOCAL_CS) of the site frame.
std::string siteCrsWkt(const std::string& site);
// Adds the CRS and the tags to an existing GeoTIFF; `values` says what its values are.
void tagSiteRaster(const std::string& path, const SiteTags& tags, const std::string& values);
// Reads band 1 of the raster at `path` and throws unless it is `cols` x `rows` and byte-identical to
// `data` (float32 when `float32`, else 8-bit): the proof that a GDAL write is complete (GDAL reports a failed
// write at close, where the C API does not return it to us).
void verifyRaster(const std::string& path, int cols, int rows, bool float32, const void* data);

struct Float32Raster {
  Geometry geometry;
  std::optional<float> nodata;  // band 1's, when the file has one
  bool pixel_is_area = true;    // AREA_OR_POINT (absent: Area)
  std::vector<float> values;    // rows x cols, row-major
};
// Band 1 of a north-up GeoTIFF with square cells, geotransform (east0, cell, 0, north0, 0, -cell), read as
// float32. Throws cli::InputError naming the file and the field (geotransform, band 1) otherwise.
Float32Raster readGeoTiff(const std::string& path);

// PNG of `image` (cv::imencode with `params`), written whole or not at all.
void writePng(const std::string& path, const cv::Mat& image, const std::vector<int>& params = {});

}  // namespace areomap::raster
