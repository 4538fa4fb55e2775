#include <cmath>
#include <fstream>
#include <random>
#include <string>

#include "ground/dataset/DemRaster.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "tests/ground/dataset/FileSizeLimit.hpp"
#include "tests/ground/dataset/TextFiles.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using areomap::test::contains;
using areomap::test::writeText;

namespace {

std::string obsError(const std::string& path, const std::string& text) {
  writeText(path, text);
  try {
    (void)readObservationsCsv(path);
  } catch (const DatasetError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_GROUP(TruthFiles){};

TEST(TruthFiles, PointsAndObservationsRoundTripExactly) {
  const std::string dir = test::scratchDir("truth-roundtrip");
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-60.0, 60.0);
  std::vector<CheckPoint> points;
  std::vector<ImageObservation> obs;
  for (int i = 0; i < 200; ++i) {
    CheckPoint p;
    p.point = i * 3 + 1;
    p.site_m = Eigen::Vector3d(u(rng), u(rng), u(rng) / 30.0);
    points.push_back(p);
    ImageObservation o;
    o.point = p.point;
    o.image = "p" + std::to_string(i % 7) + "_L";
    o.sample_px = u(rng) + 500.0;
    o.line_px = u(rng) * 1e-7;
    o.kind = i % 2 == 0 ? "intra" : "inter";
    obs.push_back(o);
  }
  writePointsCsv(dir + "/" + kTruthPointsFile, points);
  writeObservationsCsv(dir + "/" + kTruthObservationsFile, obs);
  writeObservationsCsv(dir + "/ties.csv", obs, true);
  const std::vector<CheckPoint> p2 = readPointsCsv(dir + "/" + kTruthPointsFile);
  const std::vector<ImageObservation> o2 = readObservationsCsv(dir + "/" + kTruthObservationsFile);
  const std::vector<ImageObservation> o3 = readTiePointsCsv(dir + "/ties.csv");
  CHECK_EQUAL(points.size(), p2.size());
  CHECK_EQUAL(obs.size(), o2.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    CHECK_EQUAL(points[i].point, p2[i].point);
    CHECK(points[i].site_m == p2[i].site_m);  // bit-exact
    CHECK_EQUAL(obs[i].image, o2[i].image);
    CHECK(obs[i].sample_px == o2[i].sample_px);
    CHECK(obs[i].line_px == o2[i].line_px);
    CHECK(o2[i].kind.empty());
    CHECK_EQUAL(obs[i].kind, o3[i].kind);
  }
  std::ifstream in(dir + "/" + kTruthObservationsFile);
  std::string header;
  std::getline(in, header);
  CHECK_EQUAL(std::string("point,image,sample_px,line_px"), header);
}

TEST(TruthFiles, ColumnsByNameCommentsAndBlankLines) {
  const std::string dir = test::scratchDir("truth-columns");
  const std::string path = dir + "/t.csv";
  CHECK_EQUAL(std::string(""), obsError(path, "# tie points\nline_px, image ,point,sample_px,score\r\n\n2.5,p1_R,7,1e2,0.9\r\n"));
  const std::vector<ImageObservation> o = readObservationsCsv(path);
  CHECK_EQUAL(1u, o.size());
  CHECK_EQUAL(7, o[0].point);
  CHECK_EQUAL(std::string("p1_R"), o[0].image);
  DOUBLES_EQUAL(100.0, o[0].sample_px, 0.0);
  DOUBLES_EQUAL(2.5, o[0].line_px, 0.0);
}

TEST(TruthFiles, BadCsvNamesFileLineAndColumn) {
  const std::string dir = test::scratchDir("truth-bad");
  const std::string path = dir + "/bad.csv";
  CHECK(contains(obsError(path, ""), "bad.csv: line 1: empty file"));
  CHECK(contains(obsError(path, "point,image,sample_px\n"), "bad.csv: line 1: header lacks the column 'line_px'"));
  CHECK(contains(obsError(path, "point,image,sample_px,line_px\n1,a,2,3\n2,b,x,3\n"),
                 "bad.csv: line 3, column 3 (sample_px): expected a finite number, got 'x'"));
  CHECK(contains(obsError(path, "point,image,sample_px,line_px\n1.5,a,2,3\n"), "line 2, column 1 (point): expected an integer"));
  CHECK(contains(obsError(path, "point,image,sample_px,line_px\n1,a,2\n"), "line 2, column 4 (line_px): missing value"));
  CHECK(contains(obsError(path, "point,image,sample_px,line_px\n1,,2,3\n"), "line 2, column 2 (image): empty image stem"));
  CHECK(contains(obsError(path, "point,image,sample_px,line_px\n1,a,nan,3\n"), "column 3 (sample_px)"));
  CHECK(contains(obsError(dir + "/absent.csv", "x"), ""));
  try {
    (void)readPointsCsv(dir + "/none.csv");
    FAIL("no error");
  } catch (const DatasetError& e) {
    CHECK(contains(e.what(), "none.csv: cannot open"));
  }
  writeText(path, "point,x_m,y_m,z_m\n1,2,3,4e\n");
  try {
    (void)readPointsCsv(path);
    FAIL("no error");
  } catch (const DatasetError& e) {
    CHECK(contains(e.what(), "line 2, column 4 (z_m)"));
  }
}

// CSVs written on a full disk (a 1 KiB file-size limit): DatasetError naming the file, the previous file
// byte for byte, no temporary left.
TEST(TruthFiles, FailedWriteLeavesThePreviousFileWhole) {
  const std::string dir = test::scratchDir("truth-full");
  std::vector<ImageObservation> obs;
  std::vector<CheckPoint> points;
  for (int i = 0; i < 200; ++i) {
    obs.push_back(ImageObservation{i, "p000_L", 100.25 + i, 200.5 - i, "intra"});
    CheckPoint p;
    p.point = i;
    p.site_m = Eigen::Vector3d(0.1 * i, -0.2 * i, 1.5);
    points.push_back(p);
  }
  const std::string obs_path = dir + "/tiepoints.csv", pts_path = dir + "/truth/points.csv";
  writeObservationsCsv(obs_path, std::vector<ImageObservation>(obs.begin(), obs.begin() + 5), true);
  writePointsCsv(pts_path, std::vector<CheckPoint>(points.begin(), points.begin() + 5));
  const std::string obs_before = test::fileBytes(obs_path), pts_before = test::fileBytes(pts_path);
  int thrown = 0;
  {
    test::FileSizeLimit full(1024);
    try {
      writeObservationsCsv(obs_path, obs, true);
    } catch (const DatasetError& e) {
      thrown += contains(e.what(), obs_path + ": cannot write") ? 1 : 0;
    }
    try {
      writePointsCsv(pts_path, points);
    } catch (const DatasetError& e) {
      thrown += contains(e.what(), pts_path + ": cannot write") ? 1 : 0;
    }
  }
  CHECK_EQUAL(2, thrown);
  CHECK(test::fileBytes(obs_path) == obs_before);
  CHECK(test::fileBytes(pts_path) == pts_before);
  CHECK(test::temporariesIn(dir).empty());
  // Without the limit the same writes go through.
  writeObservationsCsv(obs_path, obs, true);
  CHECK_EQUAL(obs.size(), readObservationsCsv(obs_path).size());
}

TEST(TruthFiles, DemGeoTiffFollowsTheRasterContract) {
  const std::string dir = test::scratchDir("truth-dem");
  DemGrid g;
  g.east0_m = -50.0;
  g.north0_m = 50.0;
  g.cell_m = 0.25;
  g.cols = 40;
  g.rows = 30;
  g.values.assign(static_cast<std::size_t>(g.cols) * g.rows, 0.0f);
  for (int r = 0; r < g.rows; ++r) {
    for (int c = 0; c < g.cols; ++c) g.at(c, r) = static_cast<float>(0.01 * c - 0.02 * r);
  }
  g.at(3, 4) = g.nodata;
  const std::string path = dir + "/" + kTruthDemFile;
  writeDemGeoTiff(path, g);
  const DemGrid back = readDemGeoTiff(path);
  CHECK_EQUAL(g.cols, back.cols);
  CHECK_EQUAL(g.rows, back.rows);
  DOUBLES_EQUAL(-50.0, back.east0_m, 0.0);
  DOUBLES_EQUAL(50.0, back.north0_m, 0.0);
  DOUBLES_EQUAL(0.25, back.cell_m, 0.0);
  CHECK(g.nodata == back.nodata);
  CHECK(back.pixel_is_area);
  CHECK(g.values == back.values);
  DOUBLES_EQUAL(49.875, back.northOfRow(0), 1e-12);
  DOUBLES_EQUAL(-49.875, back.eastOfCol(0), 1e-12);
  try {
    writeDemGeoTiff(dir + "/x.tif", DemGrid{});
    FAIL("empty grid accepted");
  } catch (const DatasetError& e) {
    CHECK(contains(e.what(), "x.tif"));
  }
  try {
    (void)readDemGeoTiff(dir + "/absent.tif");
    FAIL("absent file accepted");
  } catch (const DatasetError& e) {
    CHECK(contains(e.what(), "absent.tif"));
  }
}
