// A dataset's model files (models/, truth/models/) through ground/io's CameraFile, the one camera reader and
// writer: exact round trip, errors naming the file and the component, whole-or-nothing writes.
#include <string>

#include "ground/cli/Cli.hpp"
#include "ground/io/CameraFile.hpp"
#include "tests/ground/dataset/FileSizeLimit.hpp"
#include "tests/ground/dataset/TextFiles.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using areomap::test::contains;
using areomap::test::writeText;

TEST_GROUP(ModelFile){};

namespace {

CameraModel sampleCahvor() {
  CameraModel m;
  m.type = CameraType::kCahvor;
  m.c = Vec3(0.1234567890123, -0.2, -1.5);
  m.a = Vec3(0.6, 0.8, 0.0);
  m.h = Vec3(-987.6543210987, 740.7, 0.1) + 511.5 * m.a;
  m.v = Vec3(0.0, 0.0, 1234.5) + 511.5 * m.a;
  m.o = Vec3(0.6, 0.79, 0.1).normalized();
  m.r = Vec3(0.0, 0.006, -0.004);
  m.width = 1024;
  m.height = 1024;
  return m;
}

}  // namespace

TEST(ModelFile, RoundTripsACahvorModelExactly) {
  const CameraModel m = sampleCahvor();
  const std::string path = test::scratchDir("model-file") + "/models/p000_L.cahvor";
  io::writeCameraModelFile(path, m);
  const CameraModel back = io::readCameraModelFile(path);
  CHECK(back.type == CameraType::kCahvor);
  CHECK(back.c == m.c);
  CHECK(back.a == m.a);
  CHECK(back.h == m.h);
  CHECK(back.v == m.v);
  CHECK(back.o == m.o);
  CHECK(back.r == m.r);
  CHECK_EQUAL(1024, back.width);
}

TEST(ModelFile, BadFilesNameTheFileAndTheComponent) {
  const std::string dir = test::scratchDir("model-file-bad");
  try {
    (void)io::readCameraModelFile(dir + "/absent.cahvor");
    FAIL("no error");
  } catch (const cli::InputError& e) {
    CHECK(contains(e.what(), "absent.cahvor: file: cannot open"));
  }
  writeText(dir + "/bad.cahvor", "C = 0 0 0\nA = 1 0 0\nH = 0 1000 0\n");
  try {
    (void)io::readCameraModelFile(dir + "/bad.cahvor");
    FAIL("no error");
  } catch (const cli::InputError& e) {
    printf("\n%s\n", e.what());
    CHECK(contains(e.what(), "bad.cahvor: V"));
  }
}

// A model written on a full disk (a 64-byte file-size limit): an InputError naming the file; the previous
// model is still there byte for byte, a new one is absent, and no temporary is left.
TEST(ModelFile, FailedWriteLeavesThePreviousFileWhole) {
  const CameraModel m = sampleCahvor();
  const std::string dir = test::scratchDir("model-file-full");
  const std::string path = dir + "/models/p000_L.cahvor";
  io::writeCameraModelFile(path, m);
  const std::string before = test::fileBytes(path);
  CHECK(before.size() > 64);
  CameraModel moved = m;
  moved.c.x() += 1.0;
  for (const std::string& target : {path, dir + "/models/new.cahvor"}) {
    bool thrown = false;
    {
      test::FileSizeLimit full(64);
      try {
        io::writeCameraModelFile(target, moved);
      } catch (const cli::InputError& e) {
        thrown = true;
        printf("\n%s\n", e.what());
        CHECK(contains(e.what(), target + ": cannot write"));
      }
    }
    CHECK(thrown);
  }
  CHECK(test::fileBytes(path) == before);
  CHECK(!test::fileExists(dir + "/models/new.cahvor"));
  CHECK(test::temporariesIn(dir).empty());
}
