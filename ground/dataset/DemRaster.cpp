#include "ground/dataset/DemRaster.hpp"

#include <cmath>
#include <filesystem>
#include <mutex>

#include <gdal_priv.h>

namespace areomap {
namespace {

constexpr const char* kSiteFrameWkt =
    "LOCAL_CS[\"areomap site frame (east = +Y, north = +X, up = -Z)\",LOCAL_DATUM[\"site\",0],"
    "UNIT[\"metre\",1],AXIS[\"Easting\",EAST],AXIS[\"Northing\",NORTH]]";

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
  registerOnce();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  if (driver == nullptr) throw DatasetError(path, "", "GDAL has no GTiff driver");
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  char** options = nullptr;
  options = CSLSetNameValue(options, "COMPRESS", "DEFLATE");
  options = CSLSetNameValue(options, "PREDICTOR", "3");
  options = CSLSetNameValue(options, "TILED", "YES");
  GDALDataset* ds = driver->Create(path.c_str(), grid.cols, grid.rows, 1, GDT_Float32, options);
  CSLDestroy(options);
  if (ds == nullptr) throw DatasetError(path, "", std::string("cannot create GeoTIFF: ") + CPLGetLastErrorMsg());
  double transform[6] = {grid.east0_m, grid.cell_m, 0.0, grid.north0_m, 0.0, -grid.cell_m};
  ds->SetGeoTransform(transform);
  // A local engineering frame (site metres): with it the GeoTIFF keys are written, and so is
  // GTRasterTypeGeoKey = PixelIsArea.
  ds->SetProjection(kSiteFrameWkt);
  ds->SetMetadataItem(GDALMD_AREA_OR_POINT, GDALMD_AOP_AREA);
  GDALRasterBand* band = ds->GetRasterBand(1);
  band->SetNoDataValue(grid.nodata);
  const CPLErr err = band->RasterIO(GF_Write, 0, 0, grid.cols, grid.rows, const_cast<float*>(grid.values.data()),
                                    grid.cols, grid.rows, GDT_Float32, 0, 0);
  GDALClose(ds);
  if (err != CE_None) throw DatasetError(path, "", std::string("write failed: ") + CPLGetLastErrorMsg());
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
