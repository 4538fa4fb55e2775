#include "ground/dem/DemProducts.hpp"

#include "ground/cli/AtomicFile.hpp"
#include "ground/raster/RasterFiles.hpp"

namespace areomap::dem {

void writeSiteDem(const std::string& path, const DemGrid& grid, const DemMetadata& m, const std::string& values) {
  writeDemGeoTiff(path, grid);
  raster::tagSiteRaster(path, m, values);
  raster::verifyRaster(path, grid.cols, grid.rows, true, grid.values.data());
}

void writeDemProducts(const std::string& dir, const KrigingResult& r, const DemMetadata& metadata,
                      const std::string& stem, const DemSeen* seen) {
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
      if (seen == nullptr || seen->classes.size() != r.elevation.values.size()) return;
      cli::writeViaTemporary(dir + "/" + stem + "_seen.tif", [&](const std::string& seen_tmp) {
        const DemGrid& g = r.elevation;
        raster::writeGeoTiff(seen_tmp, raster::Geometry{g.cols, g.rows, g.east0_m, g.north0_m, g.cell_m},
                             seen->classes.data(), kCellUnseen);
        raster::tagSiteRaster(seen_tmp, m, "0 unseen (nodata), 1 interpolated, 2 measured");
        raster::verifyRaster(seen_tmp, g.cols, g.rows, false, seen->classes.data());
      });
    });
  });
}

}  // namespace areomap::dem
