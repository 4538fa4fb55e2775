// DEM-like GeoTIFFs of DESIGN.md "Rasters" (dem.tif, dem_sigma.tif, truth/dem.tif): float32, north-up,
// pixel-is-area, geotransform (east0, cell, 0, north0, 0, -cell) with east = site +Y and north = site +X in
// site metres, (east0, north0) the outer corner of the first cell; values elevation up (-Z), nodata set.
#pragma once

#include <string>
#include <vector>

#include "ground/dataset/DatasetError.hpp"

namespace areomap {

struct DemGrid {
  double east0_m = 0.0;   // west edge of the first column (site +Y)
  double north0_m = 0.0;  // north edge of the first row (site +X)
  double cell_m = 1.0;
  int cols = 0;           // columns go east
  int rows = 0;           // rows go south
  float nodata = -32768.0f;
  bool pixel_is_area = true;  // as read (AREA_OR_POINT); always written as Area
  std::vector<float> values;  // rows * cols, row-major; elevation up (-Z) in metres, or nodata

  float& at(int col, int row) { return values[static_cast<std::size_t>(row) * cols + col]; }
  float at(int col, int row) const { return values[static_cast<std::size_t>(row) * cols + col]; }
  // Site coordinates of a cell centre.
  double northOfRow(int row) const { return north0_m - (row + 0.5) * cell_m; }
  double eastOfCol(int col) const { return east0_m + (col + 0.5) * cell_m; }
};

// Writes a GeoTIFF (float32, one band, nodata, AREA_OR_POINT=Area; ground/raster writes it). Throws
// DatasetError on failure.
void writeDemGeoTiff(const std::string& path, const DemGrid& grid);
// Reads band 1 of a north-up GeoTIFF into a DemGrid (nodata from the file, else the default).
DemGrid readDemGeoTiff(const std::string& path);

}  // namespace areomap
