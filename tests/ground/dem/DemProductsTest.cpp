#include <string>

#include <gdal_priv.h>

#include "ground/dem/DemProducts.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap::dem;

TEST_GROUP(DemProducts){};

TEST(DemProducts, GeoTiffsCarryGridCrsAndMetadata) {
  std::vector<DemPoint> pts;
  for (int i = 0; i < 20; ++i) {
    for (int j = 0; j < 20; ++j) pts.push_back(DemPoint{i * 0.5, j * 0.5 - 3.0, 0.1 * i, 0.01, -1});
  }
  areomap::DemGrid g;
  g.cell_m = 0.25;
  g.east0_m = -3.0;
  g.north0_m = 9.75;
  g.cols = 40;
  g.rows = 40;
  const KrigingResult r = krigeDem(pts, g, KrigingOptions{});
  const std::string dir = areomap::test::scratchDir("dem_products");
  writeDemProducts(dir, r, DemMetadata{"testsite", {3, 4}, ""});
  GDALAllRegister();
  for (const char* name : {"/dem.tif", "/dem_sigma.tif"}) {
    GDALDataset* ds = static_cast<GDALDataset*>(GDALOpen((dir + name).c_str(), GA_ReadOnly));
    CHECK(ds != nullptr);
    double gt[6];
    CHECK(ds->GetGeoTransform(gt) == CE_None);
    DOUBLES_EQUAL(-3.0, gt[0], 1e-9);
    DOUBLES_EQUAL(0.25, gt[1], 1e-9);
    DOUBLES_EQUAL(9.75, gt[3], 1e-9);
    DOUBLES_EQUAL(-0.25, gt[5], 1e-9);
    CHECK_EQUAL(GDT_Float32, ds->GetRasterBand(1)->GetRasterDataType());
    int has_nodata = 0;
    ds->GetRasterBand(1)->GetNoDataValue(&has_nodata);
    CHECK(has_nodata);
    STRCMP_EQUAL("testsite", ds->GetMetadataItem("AREOMAP_SITE"));
    STRCMP_EQUAL("3,4", ds->GetMetadataItem("AREOMAP_SOLS"));
    STRCMP_EQUAL("Area", ds->GetMetadataItem("AREA_OR_POINT"));
    const std::string wkt = ds->GetProjectionRef();
    CHECK(wkt.find("testsite") != std::string::npos);
    // A value: the cell at north 4.875, east -0.375 (row 19, col 10) on the plane z = 0.2 north.
    float v = 0.0f;
    CHECK(ds->GetRasterBand(1)->RasterIO(GF_Read, 10, 19, 1, 1, &v, 1, 1, GDT_Float32, 0, 0) == CE_None);
    if (std::string(name) == "/dem.tif") DOUBLES_EQUAL(0.2 * 4.875, v, 0.01);
    GDALClose(ds);
  }
}
