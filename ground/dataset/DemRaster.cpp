#include "ground/dataset/DemRaster.hpp"

#include <cmath>
#include <mutex>

#include <gdal_priv.h>

#include "ground/raster/RasterFiles.hpp"

namespace areomap {
namespace {

void registerOnce() {
  static std::once_flag flag;
  std::call_once(flag, [] { GDALAllRegister(); });
}

}  // namespace

void writeDemGeoTiff(const std::string& path, const DemGrid& grid) {
  if (grid.cols <= 0 || grid.rows <= 0 || grid.values.size() != static_cast<std::size_t>(grid.cols) * grid.rows) {
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
  registerOnce();
  GDALDataset* ds = static_cast<GDALDataset*>(GDALOpen(path.c_str(), GA_ReadOnly));
  if (ds == nullptr) throw DatasetError(path, "", std::string("cannot open raster: ") + CPLGetLastErrorMsg());
  DemGrid grid;
  double t[6];
  if (ds->GetGeoTransform(t) != CE_None) {
    GDALClose(ds);
    throw DatasetError(path, "geotransform", "missing");
  }
  if (t[2] != 0.0 || t[4] != 0.0 || !(t[1] > 0.0) || std::fabs(t[5] + t[1]) > 1e-9 * t[1]) {
    GDALClose(ds);
    throw DatasetError(path, "geotransform", "expected north-up square cells (east0, cell, 0, north0, 0, -cell)");
  }
  grid.east0_m = t[0];
  grid.cell_m = t[1];
  grid.north0_m = t[3];
  const char* aop = ds->GetMetadataItem(GDALMD_AREA_OR_POINT);
  // For a PixelIsPoint file GDAL already shifts the geotransform to the cell corner; the flag is for callers.
  grid.pixel_is_area = aop == nullptr || !EQUAL(aop, GDALMD_AOP_POINT);
  grid.cols = ds->GetRasterXSize();
  grid.rows = ds->GetRasterYSize();
  GDALRasterBand* band = ds->GetRasterBand(1);
  int has_nodata = 0;
  const double nodata = band->GetNoDataValue(&has_nodata);
  if (has_nodata != 0) grid.nodata = static_cast<float>(nodata);
  grid.values.resize(static_cast<std::size_t>(grid.cols) * grid.rows);
  const CPLErr err = band->RasterIO(GF_Read, 0, 0, grid.cols, grid.rows, grid.values.data(), grid.cols, grid.rows,
                                    GDT_Float32, 0, 0);
  GDALClose(ds);
  if (err != CE_None) throw DatasetError(path, "band 1", std::string("read failed: ") + CPLGetLastErrorMsg());
  return grid;
}

}  // namespace areomap
