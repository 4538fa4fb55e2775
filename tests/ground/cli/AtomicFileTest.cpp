#include <sys/resource.h>
#include <sys/stat.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <string>

#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

namespace fs = std::filesystem;

namespace {
std::string readAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}
int countFiles(const std::string& dir) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(dir)) n += e.is_regular_file() ? 1 : 0;
  return n;
}
}  // namespace

TEST_GROUP(AtomicFile){};

TEST(AtomicFile, WritesAndReplacesWholeFiles) {
  const std::string dir = areomap::test::scratchDir("atomic_write");
  const std::string path = dir + "/report.json";
  areomap::cli::writeFileAtomic(path, std::string("{\"a\": 1}\n"));
  STRCMP_EQUAL("{\"a\": 1}\n", readAll(path).c_str());
  areomap::cli::writeFileAtomic(path, std::string("{\"a\": 2}\n"));
  STRCMP_EQUAL("{\"a\": 2}\n", readAll(path).c_str());
  LONGS_EQUAL(1, countFiles(dir));
}

TEST(AtomicFile, UnwritableFolderNamesTheFileAndLeavesNothing) {
  const std::string dir = areomap::test::scratchDir("atomic_missing");
  const std::string path = dir + "/no/such/folder/dem.tif";
  try {
    areomap::cli::writeFileAtomic(path, std::string("x"));
    FAIL("expected an error");
  } catch (const areomap::cli::InputError& e) {
    STRCMP_CONTAINS("no/such/folder/dem.tif", e.what());
  }
  LONGS_EQUAL(0, countFiles(dir));
}

TEST(AtomicFile, FileSizeLimitLeavesNoHalfWrittenProduct) {
  const std::string dir = areomap::test::scratchDir("atomic_full");
  const std::string path = dir + "/points.ply";
  areomap::cli::writeFileAtomic(path, std::string("old"));
  // A small file-size limit stands in for a full disk: write() fails with EFBIG instead of a signal.
  std::signal(SIGXFSZ, SIG_IGN);
  rlimit old_limit{};
  getrlimit(RLIMIT_FSIZE, &old_limit);
  rlimit small = old_limit;
  small.rlim_cur = 4096;
  setrlimit(RLIMIT_FSIZE, &small);
  const std::string big(100000, 'x');
  bool threw = false;
  try {
    areomap::cli::writeFileAtomic(path, big);
  } catch (const areomap::cli::InputError& e) {
    threw = true;
    STRCMP_CONTAINS("points.ply", e.what());
  }
  setrlimit(RLIMIT_FSIZE, &old_limit);
  std::signal(SIGXFSZ, SIG_DFL);
  CHECK_TRUE(threw);
  STRCMP_EQUAL("old", readAll(path).c_str());  // the previous product is intact
  LONGS_EQUAL(1, countFiles(dir));             // no temporary left behind
}

TEST(AtomicFile, WriteViaTemporaryKeepsTheExtensionAndCleansUp) {
  const std::string dir = areomap::test::scratchDir("atomic_via");
  const std::string path = dir + "/ortho.png";
  std::string seen;
  areomap::cli::writeViaTemporary(path, [&](const std::string& tmp) {
    seen = tmp;
    std::ofstream(tmp) << "png";
  });
  CHECK(seen.size() > 4 && seen.substr(seen.size() - 4) == ".png");
  STRCMP_EQUAL("png", readAll(path).c_str());
  CHECK_THROWS(areomap::cli::InputError, areomap::cli::writeViaTemporary(dir + "/empty.tif", [](const std::string&) {}));
  CHECK_THROWS(std::runtime_error, areomap::cli::writeViaTemporary(dir + "/fail.tif", [](const std::string& tmp) {
                 std::ofstream(tmp) << "partial";
                 throw std::runtime_error("driver failed");
               }));
  LONGS_EQUAL(1, countFiles(dir));
}
