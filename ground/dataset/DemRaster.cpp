// DEM-like GeoTIFFs (DemRaster.hpp) through ground/raster, the one module that reads and writes rasters.
#include "ground/dataset/DemRaster.hpp"

#include <utility>

#include "ground/raster/RasterFiles.hpp"

namespace areomap {
namespace {

// ground/raster's error as a DatasetError with the same file, field and message.
DatasetError datasetErrorOf(const std::string& path, const cli::InputError& e) {
  const std::string what = e.what();
  const std::string prefix = path + (e.field().empty() ? std::string() : ": " + e.field()) + ": ";
  return DatasetError(path, e.field(), what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what);
}

}  // namespace

void writeDemGeoTiff(const std::string& path, const DemGrid& grid) {
  if (grid.cols <= 0 || grid.rows <= 0 ||
      grid.values.size() != static_cast<std::size_t>(grid.cols) * grid.rows) {
    throw DatasetError(path, "grid", "empty grid or values of the wrong size");
  }
  if (!(grid.cell_m > 0.0)) throw DatasetError(path, "cell_m", "cell size must be positive");
  const raster::Geometry g{grid.cols, grid.rows, grid.east0_m, grid.north0_m, grid.cell_m};
  try {
    raster::writeGeoTiff(path, g, grid.values.data(), grid.nodata);
  } catch (const cli::InputError& e) {
    throw DatasetError::from(path, e);
  }
}

DemGrid readDemGeoTiff(const std::string& path) {
  raster::Float32Raster r;
  try {
    r = raster::readGeoTiff(path);
  } catch (const cli::InputError& e) {
    throw datasetErrorOf(path, e);
  }
  DemGrid grid;
  grid.east0_m = r.geometry.east0_m;
  grid.cell_m = r.geometry.cell_m;
  grid.north0_m = r.geometry.north0_m;
  grid.pixel_is_area = r.pixel_is_area;
  grid.cols = r.geometry.cols;
  grid.rows = r.geometry.rows;
  if (r.nodata) grid.nodata = *r.nodata;
  grid.values = std::move(r.values);
  return grid;
}

}  // namespace areomap
