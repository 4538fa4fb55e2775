#include "ground/raster/RasterFiles.hpp"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <mutex>

#include <gdal_priv.h>
#include <opencv2/imgcodecs.hpp>

#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"

namespace areomap::raster {
namespace {

constexpr const char* kSiteFrameWkt =
    "LOCAL_CS[\"areomap site frame (east = +Y, north = +X, up = -Z)\",LOCAL_DATUM[\"site\",0],"
    "UNIT[\"metre\",1],AXIS[\"Easting\",EAST],AXIS[\"Northing\",NORTH]]";

void registerOnce() {
  static std::once_flag flag;
  std::call_once(flag, [] { GDALAllRegister(); });
}

GDALDriver* geoTiffDriver(const std::string& path) {
  registerOnce();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  if (driver == nullptr) throw cli::InputError(path, "", "GDAL has no GTiff driver");
  return driver;
}

}  // namespace

void writeGeoTiff(const std::string& path, const Geometry& g, const float* values, float nodata) {
  if (g.cols <= 0 || g.rows <= 0 || values == nullptr) {
    throw cli::InputError(path, "grid", "empty grid or values of the wrong size");
  }
  if (!(g.cell_m > 0.0)) throw cli::InputError(path, "cell_m", "cell size must be positive");
  GDALDriver* driver = geoTiffDriver(path);
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  char** options = nullptr;
  options = CSLSetNameValue(options, "COMPRESS", "DEFLATE");
  options = CSLSetNameValue(options, "PREDICTOR", "3");
  options = CSLSetNameValue(options, "TILED", "YES");
  GDALDataset* ds = driver->Create(path.c_str(), g.cols, g.rows, 1, GDT_Float32, options);
  CSLDestroy(options);
  if (ds == nullptr)
    throw cli::InputError(path, "", std::string("cannot create GeoTIFF: ") + CPLGetLastErrorMsg());
  double transform[6] = {g.east0_m, g.cell_m, 0.0, g.north0_m, 0.0, -g.cell_m};
  ds->SetGeoTransform(transform);
  // A local engineering frame (site metres): with it the GeoTIFF keys are written, and so is
  // GTRasterTypeGeoKey = PixelIsArea.
  ds->SetProjection(kSiteFrameWkt);
  ds->SetMetadataItem(GDALMD_AREA_OR_POINT, GDALMD_AOP_AREA);
  GDALRasterBand* band = ds->GetRasterBand(1);
  band->SetNoDataValue(nodata);
  const CPLErr err = band->RasterIO(GF_Write, 0, 0, g.cols, g.rows, const_cast<float*>(values), g.cols,
                                    g.rows, GDT_Float32, 0, 0);
  GDALClose(ds);
  if (err != CE_None) throw cli::InputError(path, "", std::string("write failed: ") + CPLGetLastErrorMsg());
}

void writeGeoTiff(const std::string& path, const Geometry& g, const uint8_t* values, uint8_t nodata) {
  GDALDriver* driver = geoTiffDriver(path);
  GDALDataset* ds = driver->Create(path.c_str(), g.cols, g.rows, 1, GDT_Byte, nullptr);
  if (ds == nullptr) throw std::runtime_error(path + ": cannot create");
  double gt[6] = {g.east0_m, g.cell_m, 0.0, g.north0_m, 0.0, -g.cell_m};
  ds->SetGeoTransform(gt);
  ds->SetMetadataItem("AREA_OR_POINT", "Area");
  GDALRasterBand* band = ds->GetRasterBand(1);
  band->SetNoDataValue(nodata);
  const CPLErr err = band->RasterIO(GF_Write, 0, 0, g.cols, g.rows, const_cast<uint8_t*>(values), g.cols,
                                    g.rows, GDT_Byte, 0, 0);
  GDALClose(ds);
  if (err != CE_None) throw std::runtime_error(path + ": write failed");
}

std::string siteCrsWkt(const std::string& site) {
  return "LOCAL_CS[\"areomap site frame " + site +
         "\",LOCAL_DATUM[\"site frame origin\",0],UNIT[\"metre\",1],AXIS[\"Easting (site +Y)\",EAST],"
         "AXIS[\"Northing (site +X)\",NORTH]]";
}

void tagSiteRaster(const std::string& path, const SiteTags& m, const std::string& values) {
  registerOnce();
  GDALDataset* ds = static_cast<GDALDataset*>(GDALOpen(path.c_str(), GA_Update));
  if (ds == nullptr) throw std::runtime_error(path + ": cannot open for update");
  const std::string wkt = siteCrsWkt(m.site);
  CPLErr err = ds->SetProjection(wkt.c_str());
  std::string sols;
  for (std::size_t i = 0; i < m.sols.size(); ++i) sols += (i ? "," : "") + std::to_string(m.sols[i]);
  if (ds->SetMetadataItem("AREOMAP_SITE", m.site.c_str()) != CE_None) err = CE_Failure;
  if (ds->SetMetadataItem("AREOMAP_SOLS", sols.c_str()) != CE_None) err = CE_Failure;
  if (ds->SetMetadataItem("AREOMAP_FRAME", "site: +X north, +Y east, +Z down; columns east, rows south") !=
      CE_None) {
    err = CE_Failure;
  }
  if (ds->SetMetadataItem("AREOMAP_VALUES", values.c_str()) != CE_None) err = CE_Failure;
  if (!m.variogram.empty() && ds->SetMetadataItem("AREOMAP_VARIOGRAM", m.variogram.c_str()) != CE_None) {
    err = CE_Failure;
  }
  GDALClose(ds);
  if (err != CE_None) throw std::runtime_error(path + ": cannot write CRS or metadata");
}

void verifyRaster(const std::string& path, int cols, int rows, bool float32, const void* data) {
  registerOnce();
  GDALDataset* ds = static_cast<GDALDataset*>(GDALOpen(path.c_str(), GA_ReadOnly));
  if (ds == nullptr) throw std::runtime_error(path + ": cannot be read back (incomplete?)");
  const std::size_t bytes = static_cast<std::size_t>(cols) * rows * (float32 ? 4 : 1);
  std::vector<unsigned char> back(bytes);
  CPLErr err = CE_Failure;
  if (ds->GetRasterXSize() == cols && ds->GetRasterYSize() == rows && ds->GetRasterCount() >= 1) {
    err = ds->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, cols, rows, back.data(), cols, rows,
                                         float32 ? GDT_Float32 : GDT_Byte, 0, 0);
  }
  GDALClose(ds);
  if (err != CE_None || std::memcmp(back.data(), data, bytes) != 0) {
    throw std::runtime_error(path + ": read back differs from what was written (incomplete?)");
  }
}

Float32Raster readGeoTiff(const std::string& path) {
  registerOnce();
  GDALDataset* ds = static_cast<GDALDataset*>(GDALOpen(path.c_str(), GA_ReadOnly));
  if (ds == nullptr)
    throw cli::InputError(path, "", std::string("cannot open raster: ") + CPLGetLastErrorMsg());
  Float32Raster out;
  double t[6];
  if (ds->GetGeoTransform(t) != CE_None) {
    GDALClose(ds);
    throw cli::InputError(path, "geotransform", "missing");
  }
  if (t[2] != 0.0 || t[4] != 0.0 || !(t[1] > 0.0) || std::fabs(t[5] + t[1]) > 1e-9 * t[1]) {
    GDALClose(ds);
    throw cli::InputError(path, "geotransform",
                          "expected north-up square cells (east0, cell, 0, north0, 0, -cell)");
  }
  Geometry& g = out.geometry;
  g.east0_m = t[0];
  g.cell_m = t[1];
  g.north0_m = t[3];
  const char* aop = ds->GetMetadataItem(GDALMD_AREA_OR_POINT);
  // For a PixelIsPoint file GDAL already shifts the geotransform to the cell corner; the flag is for callers.
  out.pixel_is_area = aop == nullptr || !EQUAL(aop, GDALMD_AOP_POINT);
  g.cols = ds->GetRasterXSize();
  g.rows = ds->GetRasterYSize();
  GDALRasterBand* band = ds->GetRasterBand(1);
  int has_nodata = 0;
  const double nodata = band->GetNoDataValue(&has_nodata);
  if (has_nodata != 0) out.nodata = static_cast<float>(nodata);
  out.values.resize(static_cast<std::size_t>(g.cols) * g.rows);
  const CPLErr err =
      band->RasterIO(GF_Read, 0, 0, g.cols, g.rows, out.values.data(), g.cols, g.rows, GDT_Float32, 0, 0);
  GDALClose(ds);
  if (err != CE_None)
    throw cli::InputError(path, "band 1", std::string("read failed: ") + CPLGetLastErrorMsg());
  return out;
}

void writePng(const std::string& path, const cv::Mat& image, const std::vector<int>& params) {
  std::vector<unsigned char> bytes;
  if (image.empty() || !cv::imencode(".png", image, bytes, params)) {
    throw cli::InputError(path, "image", "PNG encoding failed");
  }
  cli::writeFileAtomic(path, bytes.data(), bytes.size());
}

}  // namespace areomap::raster
