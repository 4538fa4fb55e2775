#include <fstream>
#include <string>

#include "ground/dataset/Dataset.hpp"
#include "tests/ground/dataset/TextFiles.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;
using areomap::test::contains;
using areomap::test::writeText;

namespace {

// Reads a panorama.json with the given text and returns the error message ("" when it reads).
std::string readError(const std::string& dir, const std::string& json) {
  writeText(dir + "/panorama.json", json);
  try {
    (void)readDataset(dir);
  } catch (const DatasetError& e) {
    return e.what();
  }
  return "";
}

Dataset fullDataset(const std::string& root) {
  Dataset ds;
  ds.root = root;
  ds.name = "full";
  ds.width = 1024;
  ds.height = 768;
  ds.rig.gimbal_m[1] = Eigen::Vector3d(0.1, -0.2, -1.5);
  ds.rig.gimbal_m[3] = Eigen::Vector3d(2.0 / 3.0, 1e-17, -1.4999999999999998);
  ds.rig.left_offset_m = Eigen::Vector3d(-0.1, 0.05, -0.02);
  ds.rig.right_offset_m = Eigen::Vector3d(0.1, 0.05, -0.02);
  ds.rig.base_m = Eigen::Vector3d(0.2, 0.0, 0.001);
  ds.rig.sigma_gimbal_m = 0.001;
  ds.rig.sigma_base_m = 0.0005;
  for (int i = 0; i < 3; ++i) {
    Pair p;
    p.id = 10 + i;
    p.sol = i == 2 ? 3 : 1;
    p.tier = i;
    const std::string s = "p00" + std::to_string(i);
    p.left = makeImageRef(root, "images/" + s + "_L.png", "models/" + s + "_L.cahvor");
    if (i != 1) p.right = makeImageRef(root, "images/" + s + "_R.png", "models/" + s + "_R.cahvor");
    ds.pairs.push_back(p);
  }
  return ds;
}

}  // namespace

TEST_GROUP(Dataset){};

TEST(Dataset, RoundTripsEveryField) {
  const std::string dir = test::scratchDir("dataset-roundtrip");
  const Dataset ds = fullDataset(dir);
  writeDataset(ds, dir);
  const Dataset back = readDataset(dir);
  CHECK_EQUAL(ds.name, back.name);
  CHECK_EQUAL(1024, back.width);
  CHECK_EQUAL(768, back.height);
  CHECK_EQUAL(2u, back.rig.gimbal_m.size());
  // Exact: the JSON writer prints the shortest text that reads back to the same double.
  CHECK(ds.rig.gimbal_m.at(3) == back.rig.gimbal_m.at(3));
  CHECK(ds.rig.gimbal_m.at(1) == back.rig.gimbal_m.at(1));
  CHECK(back.rig.left_offset_m && *back.rig.left_offset_m == *ds.rig.left_offset_m);
  CHECK(back.rig.right_offset_m && *back.rig.right_offset_m == *ds.rig.right_offset_m);
  CHECK(back.rig.base_m && *back.rig.base_m == *ds.rig.base_m);
  DOUBLES_EQUAL(0.001, *back.rig.sigma_gimbal_m, 0.0);
  DOUBLES_EQUAL(0.0005, *back.rig.sigma_base_m, 0.0);
  CHECK_EQUAL(3u, back.pairs.size());
  for (std::size_t i = 0; i < 3; ++i) {
    CHECK_EQUAL(ds.pairs[i].id, back.pairs[i].id);
    CHECK_EQUAL(ds.pairs[i].sol, back.pairs[i].sol);
    CHECK_EQUAL(ds.pairs[i].tier, back.pairs[i].tier);
    CHECK_EQUAL(ds.pairs[i].left.image, back.pairs[i].left.image);
    CHECK_EQUAL(ds.pairs[i].left.stem, back.pairs[i].left.stem);
    CHECK_EQUAL(dir + "/" + ds.pairs[i].left.image, back.pairs[i].left.image_path);
    CHECK_EQUAL(*ds.pairs[i].left.model, *back.pairs[i].left.model);
    CHECK_EQUAL(dir + "/" + *ds.pairs[i].left.model, back.pairs[i].left.model_path);
    CHECK_EQUAL(ds.pairs[i].right.has_value(), back.pairs[i].right.has_value());
  }
  CHECK_EQUAL(std::string("p000_L"), back.pairs[0].left.stem);
  CHECK_EQUAL(std::string("p002_R"), back.pairs[2].right->stem);
  CHECK_EQUAL(5, back.imageCount());
  int index = -1;
  bool right = false;
  CHECK(back.findStem("p002_R", index, right));
  CHECK_EQUAL(2, index);
  CHECK(right);
  CHECK_FALSE(back.findStem("p001_R", index, right));
  CHECK(back.notes.empty());
}

TEST(Dataset, OnlyTheLeftImageIsRequiredAndDefaultsAreNoted) {
  const std::string dir = test::scratchDir("dataset-minimal");
  CHECK_EQUAL(std::string(""), readError(dir, R"({"pairs": [{"left": {"image": "a/x.png"}},
                                                            {"left": {"image": "b.IMG"}, "extra": 5}],
                                                  "unknown_key": {"anything": [1, 2]}})"));
  const Dataset ds = readDataset(dir);
  CHECK_EQUAL(std::string("dataset-minimal"), ds.name);
  CHECK_EQUAL(0, ds.width);
  CHECK_EQUAL(2u, ds.pairs.size());
  CHECK_EQUAL(0, ds.pairs[0].id);
  CHECK_EQUAL(1, ds.pairs[1].id);
  CHECK_EQUAL(0, ds.pairs[1].sol);
  CHECK_EQUAL(0, ds.pairs[1].tier);
  CHECK_FALSE(ds.pairs[0].right.has_value());
  CHECK_FALSE(ds.pairs[0].left.model.has_value());
  CHECK(ds.pairs[0].left.model_path.empty());
  CHECK_EQUAL(std::string("b"), ds.pairs[1].left.stem);
  CHECK(ds.rig.gimbal_m.empty());
  CHECK_FALSE(ds.rig.base_m.has_value());
  // Every absent optional item is named in the notes.
  const char* expected[] = {"name:", "image_size:", "pairs[].id:", "pairs[].sol:", "pairs[].tier:", "model:",
                            "rig.gimbal_m.0:", "rig.left_offset_m:", "rig.right_offset_m:", "rig.base_m:",
                            "rig.sigma_gimbal_m:", "rig.sigma_base_m:"};
  for (const char* e : expected) {
    bool found = false;
    for (const std::string& n : ds.notes) found = found || n.rfind(e, 0) == 0;
    if (!found) FAIL(e);
  }
  CHECK_EQUAL(sizeof(expected) / sizeof(expected[0]), ds.notes.size());
}

TEST(Dataset, BadInputsNameTheFileAndTheField) {
  const std::string dir = test::scratchDir("dataset-bad");
  struct Case {
    const char* json;
    const char* field;
  };
  const Case cases[] = {
      {R"({"name": "x"})", "panorama.json: pairs: missing"},
      {R"({"pairs": []})", "panorama.json: pairs: empty"},
      {R"({"pairs": [{"right": {"image": "r.png"}}]})", "pairs[0].left: missing"},
      {R"({"pairs": [{"left": {"model": "m.cahvor"}}]})", "pairs[0].left.image: missing"},
      {R"({"pairs": [{"left": {"image": 5}}]})", "pairs[0].left.image: expected a string"},
      {R"({"pairs": [{"left": {"image": "a.png"}, "sol": "one"}]})", "pairs[0].sol: expected an integer"},
      {R"({"pairs": [{"left": {"image": "a.png"}, "tier": 1.5}]})", "pairs[0].tier: expected an integer"},
      {R"({"pairs": [{"left": {"image": "a.png"}, "id": 4}, {"left": {"image": "b.png"}, "id": 4}]})",
       "pairs[1].id: duplicate id 4"},
      {R"({"pairs": [{"left": {"image": "a.png"}, "right": {"image": "x/a.jpg"}}]})",
       "pairs[0].right.image: image stem 'a' is already used by pairs[0].left.image"},
      {R"({"image_size": [1024], "pairs": [{"left": {"image": "a.png"}}]})", "image_size: expected [width, height]"},
      {R"({"image_size": [1024, -1], "pairs": [{"left": {"image": "a.png"}}]})", "image_size[1]: height must be positive"},
      {R"({"rig": {"base_m": [0.2, 0]}, "pairs": [{"left": {"image": "a.png"}}]})", "rig.base_m: expected an array"},
      {R"({"rig": {"base_m": [0.2, 0, "z"]}, "pairs": [{"left": {"image": "a.png"}}]})", "rig.base_m[2]: expected a number"},
      {R"({"rig": {"gimbal_m": {"one": [0, 0, -1.5]}}, "pairs": [{"left": {"image": "a.png"}}]})",
       "rig.gimbal_m.one: the key must be a sol number"},
      {R"({"rig": {"sigma_base_m": 0}, "pairs": [{"left": {"image": "a.png"}}]})", "rig.sigma_base_m: must be positive"},
      {R"({"pairs": [{"left": {"image": "a.png"}})", "panorama.json: not valid JSON"},
      // Found by fuzz_panorama: a number beyond double threw nlohmann's out_of_range past the reader.
      {R"({"name": 1e1111, "pairs": [{"left": {"image": "a.png"}}]})", "panorama.json: not valid JSON"},
      {R"([1, 2])", "panorama.json: expected a JSON object"},
  };
  for (const Case& c : cases) {
    const std::string error = readError(dir, c.json);
    if (!contains(error, c.field)) {
      printf("\njson: %s\nerror: '%s'\nexpected to contain: '%s'\n", c.json, error.c_str(), c.field);
      FAIL("error does not name the field");
    }
  }
  const std::string none = test::scratchDir("dataset-none");
  CHECK(contains(readError(none + "/missing", "{}"), "panorama.json: cannot open"));
}

TEST(Dataset, PathEscapesAreRejected) {
  const std::string dir = test::scratchDir("dataset-escape");
  const char* bad_paths[] = {"/etc/passwd", "../outside.png", "images/../../x.png", "images/..", "..", "",
                             "\\\\server\\share.png", "C:\\x.png"};
  for (const char* p : bad_paths) {
    std::string escaped;
    for (char ch : std::string(p)) {
      if (ch == '\\') escaped += "\\\\";
      else escaped += ch;
    }
    const std::string json_model =
        std::string(R"({"pairs": [{"left": {"image": "ok.png"}}, {"left": {"image": "b.png", "model": ")") + escaped + R"("}}]})";
    const std::string json_image = std::string(R"({"pairs": [{"left": {"image": ")") + escaped + R"("}}]})";
    const std::string e1 = readError(dir, json_model);
    const std::string e2 = readError(dir, json_image);
    if (!contains(e1, "pairs[1].left.model: ") || !contains(e2, "pairs[0].left.image: ")) {
      printf("\npath '%s': '%s' / '%s'\n", p, e1.c_str(), e2.c_str());
      FAIL("path escape not rejected");
    }
  }
  // Names that merely contain dots are fine.
  CHECK_EQUAL(std::string(""), readError(dir, R"({"pairs": [{"left": {"image": "images/..x/a..b.png"}}]})"));
  // The writer refuses to write an escaping path too.
  Dataset ds = fullDataset(dir);
  ds.pairs[1].left.image = "../x.png";
  try {
    writeDataset(ds, dir);
    FAIL("writeDataset accepted '..'");
  } catch (const DatasetError& e) {
    CHECK(contains(e.what(), "pairs[1].left.image"));
  }
}

TEST(Dataset, MissingFilesAreNamedByField) {
  const std::string dir = test::scratchDir("dataset-files");
  Dataset ds = fullDataset(dir);
  writeDataset(ds, dir);
  ds = readDataset(dir);
  try {
    checkDatasetFiles(ds, true, true);
    FAIL("missing image not reported");
  } catch (const DatasetError& e) {
    CHECK(contains(e.what(), "panorama.json: pairs[0].left.image: file not found"));
  }
  checkDatasetFiles(ds, false, false);
}

TEST(Dataset, UnwritableFolderIsAnError) {
  const std::string dir = test::scratchDir("dataset-unwritable");
  writeText(dir + "/file", "x");
  try {
    writeDataset(fullDataset(dir), dir + "/file/sub");
    FAIL("no error");
  } catch (const DatasetError& e) {
    CHECK(contains(e.what(), "file/sub"));
  }
}

TEST(Dataset, PathHelpers) {
  CHECK_EQUAL(std::string("p000_L"), pathStem("images/p000_L.png"));
  CHECK_EQUAL(std::string("x.tar"), pathStem("a/b/x.tar.gz"));
  CHECK_EQUAL(std::string(".hidden"), pathStem("a/.hidden"));
  CHECK_EQUAL(std::string("noext"), pathStem("noext"));
  std::string why;
  CHECK(isSafeRelativePath("a/b/c.png", why));
  CHECK_FALSE(isSafeRelativePath("a/../c.png", why));
}
