#include "ground/dem/DemProducts.hpp"

#include <cstring>
#include <stdexcept>
#include <vector>

#include <gdal_priv.h>

#include "ground/cli/AtomicFile.hpp"

namespace areomap::dem {

std::string siteCrsWkt(const std::string& site) {
  return "LOCAL_CS[\"areomap site frame " + site +
         "\",LOCAL_DATUM[\"site frame origin\",0],UNIT[\"metre\",1],AXIS[\"Easting (site +Y)\",EAST],"
         "AXIS[\"Northing (site +X)\",NORTH]]";
}

void tagSiteRaster(const std::string& path, const DemMetadata& m, const std::string& values) {
  GDALAllRegister();
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
  GDALAllRegister();
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

void writeSiteDem(const std::string& path, const DemGrid& grid, const DemMetadata& m, const std::string& values) {
  writeDemGeoTiff(path, grid);
  tagSiteRaster(path, m, values);
  verifyRaster(path, grid.cols, grid.rows, true, grid.values.data());
}

void writeDemProducts(const std::string& dir, const KrigingResult& r, const DemMetadata& metadata,
                      const std::string& stem) {
  DemMetadata m = metadata;
  m.variogram = std::string(variogramName(r.model.kind)) + " nugget_m2=" + std::to_string(r.model.nugget_m2) +
                " partial_sill_m2=" + std::to_string(r.model.partial_sill_m2) +
                " range_m=" + std::to_string(r.model.range_m) + " sigma_scale=" + std::to_string(r.sigma_scale);
  // The sigma raster is renamed into place only once the DEM's temporary is complete, and the DEM right
  // after it: a failure leaves the previous pair (or none), never a new DEM with an old sigma.
  cli::writeViaTemporary(dir + "/" + stem + ".tif", [&](const std::string& dem_tmp) {
    writeSiteDem(dem_tmp, r.elevation, m, "elevation up (-Z), metres");
    cli::writeViaTemporary(dir + "/" + stem + "_sigma.tif", [&](const std::string& sigma_tmp) {
      writeSiteDem(sigma_tmp, r.sigma, m, "kriging standard deviation, metres");
    });
  });
}

}  // namespace areomap::dem
