// Products are never half-written: a full disk (a small RLIMIT_FSIZE with
// SIGXFSZ ignored: write() fails with EFBIG as on a full disk) or a folder that cannot be written gives an
// error naming each product that failed, and leaves every product either complete or as it was before.
// Also: the finer DEM near the rover, and the residual plots filled when the caller gives no residuals.
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "ground/dataset/DemRaster.hpp"
#include "ground/ortho/Orthoimage.hpp"
#include "ground/products/Products.hpp"
#include "tests/ground/products/SimScene.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
namespace fs = std::filesystem;

namespace {

const test::SimScene& scene() {
  static const test::SimScene s = test::makeSimScene("tiny", 2);
  return s;
}

products::ProductOptions options() {
  products::ProductOptions o;
  o.dense_max_disparity_px = 64;
  o.max_range_m = 18.0;   // the tiny terrain ends at 20 m
  o.cell_m = 0.05;        // dem.tif coarser than 2 cm: dem_near.tif is made too
  o.near_range_m = 3.0;
  return o;
}

std::string readBytes(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// Every regular file under `dir` (relative name -> bytes).
std::map<std::string, std::string> snapshot(const std::string& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.is_regular_file()) files[fs::relative(e.path(), dir).generic_string()] = readBytes(e.path().string());
  }
  return files;
}

// A product file is complete: rasters and PNGs decode to their full size, the PLY holds as many bytes as
// its header announces, HTML ends with its closing tag.
bool complete(const std::string& path) {
  const std::string ext = fs::path(path).extension().string();
  if (ext == ".tif" && path.find("ortho") == std::string::npos) {
    try {
      const DemGrid g = readDemGeoTiff(path);
      return g.cols > 0 && g.values.size() == static_cast<std::size_t>(g.cols) * g.rows;
    } catch (const std::exception&) {
      return false;
    }
  }
  if (ext == ".tif" || ext == ".png") return !cv::imread(path, cv::IMREAD_UNCHANGED).empty();
  const std::string bytes = readBytes(path);
  if (ext == ".ply") {
    const std::size_t end = bytes.find("end_header\n");
    const std::size_t at = bytes.find("element vertex ");
    if (end == std::string::npos || at == std::string::npos) return false;
    const long long n = std::atoll(bytes.c_str() + at + 15);
    return bytes.size() == end + 11 + static_cast<std::size_t>(n) * 41;  // 3 double, 3 float, uchar, int
  }
  if (ext == ".html") return bytes.find("</html>") != std::string::npos;
  return true;
}

bool namedIn(const std::vector<std::string>& errors, const std::string& file) {
  for (const std::string& e : errors) {
    if (e.find(file) != std::string::npos) return true;
  }
  return false;
}

struct RefRun {
  std::string out;
  products::ProductsResult result;
  std::map<std::string, std::string> files;
};

const RefRun& referenceRun() {
  static const RefRun run = [] {
    RefRun r;
    r.out = test::scratchDir("products_write_ref");
    ground::AdjustReport report;
    r.result = products::makeProducts(scene().inputs, options(), r.out, &report);
    r.files = snapshot(r.out);
    return r;
  }();
  return run;
}

// makeProducts with at most `limit` bytes per file written.
products::ProductsResult runLimited(const std::string& out, rlim_t limit) {
  std::signal(SIGXFSZ, SIG_IGN);
  rlimit old_limit{};
  getrlimit(RLIMIT_FSIZE, &old_limit);
  rlimit small = old_limit;
  small.rlim_cur = limit;
  setrlimit(RLIMIT_FSIZE, &small);
  ground::AdjustReport report;
  products::ProductsResult r = products::makeProducts(scene().inputs, options(), out, &report);
  setrlimit(RLIMIT_FSIZE, &old_limit);
  std::signal(SIGXFSZ, SIG_DFL);
  return r;
}

void printErrors(const products::ProductsResult& r) {
  for (const std::string& e : r.write_errors) std::printf("  write error: %s\n", e.c_str());
}

}  // namespace

TEST_GROUP(ProductsWrite){};

// With a 64 KiB file-size limit into a fresh folder: the big products fail, each named; every file that
// is there is complete and no temporary is left.
TEST(ProductsWrite, FullDiskLeavesOnlyCompleteProducts) {
  const RefRun& ref = referenceRun();
  for (const char* f : {"points.ply", "dem.tif", "dem_sigma.tif", "dem_near.tif", "dem_near_sigma.tif", "ortho.tif",
                        "report.html"}) {
    CHECK_TEXT(ref.files.count(f) == 1, f);
  }
  CHECK(ref.result.write_errors.empty());
  CHECK(ref.files.at("points.ply").size() > 65536);  // the limit below must bite
  const std::string out = test::scratchDir("products_write_full");
  const products::ProductsResult r = runLimited(out, 65536);
  printErrors(r);
  CHECK(namedIn(r.write_errors, out + "/points.ply"));
  const std::map<std::string, std::string> files = snapshot(out);
  for (const auto& kv : ref.files) {
    // A DEM is renamed into place only with its sigma and seen rasters (dem.tif, dem_sigma.tif,
    // dem_seen.tif), all named by the DEM when one is too big.
    std::string named = kv.first;
    for (const char* suffix : {"_sigma.tif", "_seen.tif"}) {
      const std::size_t at = kv.first.find(suffix);
      if (at != std::string::npos && at + std::string(suffix).size() == kv.first.size())
        named = kv.first.substr(0, at) + ".tif";
    }
    bool big = kv.second.size() > 65536;
    if (named.size() > 4 && named.compare(named.size() - 4, 4, ".tif") == 0) {
      const std::string stem = named.substr(0, named.size() - 4);
      for (const std::string& member : {named, stem + "_sigma.tif", stem + "_seen.tif"})
        big = big || (ref.files.count(member) == 1 && ref.files.at(member).size() > 65536);
    }
    if (big) CHECK_TEXT(namedIn(r.write_errors, out + "/" + named), kv.first.c_str());
    CHECK_TEXT(big == (files.count(kv.first) == 0), kv.first.c_str());
  }
  for (const auto& kv : files) {
    CHECK_TEXT(kv.first.find(".tmp-") == std::string::npos, kv.first.c_str());
    CHECK_TEXT(complete(out + "/" + kv.first), kv.first.c_str());
  }
}

// The same limit over the products of an earlier pass: what fails keeps its previous version, byte for byte.
TEST(ProductsWrite, FullDiskKeepsThePreviousProducts) {
  const RefRun& ref = referenceRun();
  const std::string out = test::scratchDir("products_write_again");
  fs::copy(ref.out, out, fs::copy_options::recursive | fs::copy_options::overwrite_existing);
  const products::ProductsResult r = runLimited(out, 65536);
  CHECK(!r.write_errors.empty());
  const std::map<std::string, std::string> files = snapshot(out);
  CHECK_EQUAL(ref.files.size(), files.size());  // nothing added: no temporary left
  for (const auto& kv : ref.files) {
    CHECK_TEXT(files.count(kv.first) == 1, kv.first.c_str());
    if (namedIn(r.write_errors, out + "/" + kv.first)) CHECK_TEXT(files.at(kv.first) == kv.second, kv.first.c_str());
    CHECK_TEXT(complete(out + "/" + kv.first), kv.first.c_str());
  }
}

// A folder that cannot be written: every product fails with its name; nothing is left in the folder.
// (Root ignores permissions: as root the products are made with the effective uid of `nobody`.)
TEST(ProductsWrite, ReadOnlyFolderNamesEveryProduct) {
  const std::string out = test::scratchDir("products_write_ro");
  fs::permissions(out, fs::perms::owner_read | fs::perms::owner_exec | fs::perms::group_read |
                           fs::perms::group_exec | fs::perms::others_read | fs::perms::others_exec);
  const uid_t euid = geteuid();
  const bool dropped = euid == 0 && seteuid(65534) == 0;
  ground::AdjustReport report;
  const products::ProductsResult r = products::makeProducts(scene().inputs, options(), out, &report);
  if (dropped) CHECK(seteuid(euid) == 0);
  fs::permissions(out, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec | fs::perms::others_read | fs::perms::others_exec);
  printErrors(r);
  for (const char* f : {"points.ply", "dem.tif", "dem_near.tif", "ortho.tif", "dem.png", "ortho.png", "report.html"}) {
    CHECK_TEXT(namedIn(r.write_errors, out + "/" + f), f);
  }
  CHECK(r.files.empty());
  CHECK(snapshot(out).empty());
}

// dem.tif at 5 cm, dem_near.tif at 2 cm within 3 m of the rover: the finer grid is at least as close to
// the true surface as the coarse one, sampled at the fine cells.
TEST(ProductsWrite, FinerDemNearTheRover) {
  const RefRun& ref = referenceRun();
  CHECK(ref.result.dem_near.has_value());
  const DemGrid near = readDemGeoTiff(ref.out + "/dem_near.tif");
  const DemGrid sigma = readDemGeoTiff(ref.out + "/dem_near_sigma.tif");
  const DemGrid coarse = readDemGeoTiff(ref.out + "/dem.tif");
  DOUBLES_EQUAL(0.02, near.cell_m, 1e-12);
  DOUBLES_EQUAL(0.05, coarse.cell_m, 1e-12);
  CHECK_EQUAL(near.cols, sigma.cols);
  const Vec3 g = scene().inputs.gimbal_site_m;
  CHECK(near.cols * near.cell_m < 2 * 3.0 + 1.2);
  CHECK(std::fabs(near.north0_m - g.x()) < 3.6);
  double e_near = 0, e_coarse = 0;
  long long n = 0;
  const DemGrid& truth = *scene().inputs.truth_dem;
  for (int r = 0; r < near.rows; ++r) {
    for (int c = 0; c < near.cols; ++c) {
      const float v = near.at(c, r);
      const double north = near.northOfRow(r), east = near.eastOfCol(c);
      if (v == near.nodata || std::hypot(north - g.x(), east - g.y()) < 1.0) continue;
      double t = 0, vc = 0;
      if (!ortho::demElevation(truth, north, east, t) || !ortho::demElevation(coarse, north, east, vc)) continue;
      e_near += (v - t) * (v - t);
      e_coarse += (vc - t) * (vc - t);
      ++n;
    }
  }
  CHECK(n > 10000);
  e_near = std::sqrt(e_near / n);
  e_coarse = std::sqrt(e_coarse / n);
  std::printf("\n  near-rover DEM (1-3 m, %lld cells of 2 cm): RMSE vs truth %.4f m; dem.tif (5 cm) there %.4f m\n", n,
              e_near, e_coarse);
  CHECK(e_near <= e_coarse * 1.02);
}

// The ground node hands over tie observations without residuals: makeProducts intersects each point
// again with the (here true) models. With N(0, 0.3 px) noise on the pixels, the sum of squared residuals
// is sigma^2 times the redundancy (2m - 3 per point seen m times) within 15 %, and report.html plots them.
TEST(ProductsWrite, ResidualPlotsFilledFromTheModels) {
  products::ProductInputs in = scene().inputs;
  in.pairs.clear();  // no dense matching: the report only
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.3);
  std::map<int, std::set<int>> images_of_point;
  for (products::ProductTie& t : in.ties) {
    t.residual_px = -1.0;
    t.pixel_px += Vec2(noise(rng), noise(rng));
    images_of_point[t.point].insert(t.image);
  }
  double redundancy = 0;
  for (const auto& kv : images_of_point) {
    if (kv.second.size() >= 2) redundancy += 2.0 * std::min<std::size_t>(kv.second.size(), 8) - 3.0;
  }
  const std::string out = test::scratchDir("products_residuals");
  ground::AdjustReport report;
  products::ProductOptions o = options();
  o.write_overlays = false;
  const products::ProductsResult r = products::makeProducts(in, o, out, &report);
  double ss = 0;
  for (double v : r.residuals_px) ss += v * v;
  const double expected = 0.3 * 0.3 * redundancy;
  std::printf("\n  %zu residuals, sum of squares %.2f px^2, expected %.2f px^2 (redundancy %.0f)\n",
              r.residuals_px.size(), ss, expected, redundancy);
  CHECK(r.residuals_px.size() > 100);
  CHECK(std::fabs(ss - expected) < 0.15 * expected);
  const std::string html = readBytes(out + "/report.html");
  CHECK(html.find("No residuals available") == std::string::npos);
  std::size_t bars = 0, filled = 0;
  for (std::size_t at = html.find("fill='#3b6ea5'"); at != std::string::npos; at = html.find("fill='#3b6ea5'", at + 1)) {
    ++bars;
    const std::size_t zero = html.rfind("height='0.0'", at);
    filled += zero == std::string::npos || zero < html.rfind("<rect", at) ? 1 : 0;
  }
  std::size_t image_bars = 0;
  for (std::size_t at = html.find("fill='#c0504d'"); at != std::string::npos; at = html.find("fill='#c0504d'", at + 1)) {
    ++image_bars;
  }
  std::printf("  histogram: %zu bins, %zu non-empty; %zu per-image bars\n", bars, filled, image_bars);
  CHECK_EQUAL(30u, bars);
  CHECK(filled >= 5);
  CHECK_EQUAL(in.images.size(), image_bars);
}
