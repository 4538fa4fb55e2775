#include "ground/dem/DemProducts.hpp"

#include <stdexcept>

#include <gdal_priv.h>

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

void writeDemProducts(const std::string& dir, const KrigingResult& r, const DemMetadata& metadata) {
  DemMetadata m = metadata;
  m.variogram = std::string(variogramName(r.model.kind)) + " nugget_m2=" + std::to_string(r.model.nugget_m2) +
                " partial_sill_m2=" + std::to_string(r.model.partial_sill_m2) +
                " range_m=" + std::to_string(r.model.range_m) + " sigma_scale=" + std::to_string(r.sigma_scale);
  const std::string dem = dir + "/dem.tif";
  const std::string sigma = dir + "/dem_sigma.tif";
  writeDemGeoTiff(dem, r.elevation);
  tagSiteRaster(dem, m, "elevation up (-Z), metres");
  writeDemGeoTiff(sigma, r.sigma);
  tagSiteRaster(sigma, m, "kriging standard deviation, metres");
}

}  // namespace areomap::dem
