#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "ground/cli/Parallel.hpp"
#include "ground/products/Products.hpp"
#include "tests/ground/products/SimScene.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

std::string fileBytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// Every file under `dir` (relative paths, sorted) but report.html, whose stage timings differ run to run.
std::vector<std::string> productFiles(const std::string& dir) {
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file() || e.path().filename() == "report.html") continue;
    files.push_back(std::filesystem::relative(e.path(), dir).string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace

TEST_GROUP(ProductsThreads){void teardown() override{cli::setThreads(0);
}
}
;

// The products pass on 1, 2 and 4 threads (pairs, rows and cells split differently each time) writes the
// same bytes: every product file, and the same figures in the result.
TEST(ProductsThreads, SameBytesForAnyThreadCount) {
  const test::SimScene scene = test::makeSimScene("tiny", 2);
  products::ProductOptions options;
  options.dense_max_disparity_px = 64;
  options.max_range_m = 18.0;  // the tiny terrain ends at 20 m
  std::vector<std::string> dirs;
  std::vector<products::ProductsResult> results;
  for (int threads : {1, 2, 4}) {
    cli::setThreads(threads);
    const std::string out = test::scratchDir("products_threads_" + std::to_string(threads));
    results.push_back(products::makeProducts(scene.inputs, options, out, nullptr));
    dirs.push_back(out);
  }
  const std::vector<std::string> files = productFiles(dirs[0]);
  CHECK(files.size() >= 6);
  for (std::size_t k = 1; k < dirs.size(); ++k) {
    CHECK(productFiles(dirs[k]) == files);
    for (const std::string& f : files)
      CHECK_TEXT(fileBytes(dirs[0] + "/" + f) == fileBytes(dirs[k] + "/" + f), f.c_str());
    CHECK_EQUAL(results[0].points, results[k].points);
    CHECK_EQUAL(results[0].pairs_matched, results[k].pairs_matched);
    CHECK(results[0].warnings == results[k].warnings);
    CHECK(results[0].dem->values == results[k].dem->values);
    CHECK(results[0].dem_sigma->values == results[k].dem_sigma->values);
  }
  CHECK(results[0].points > 10000);
  std::printf("\n  tiny x2: %zu product files, %lld points, the same bytes on 1, 2 and 4 threads\n",
              files.size(), results[0].points);
}
