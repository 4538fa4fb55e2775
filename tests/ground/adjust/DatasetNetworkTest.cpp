// DatasetNetwork's a-priori models: an M2020 JSON model is put into the pixel frame of the pair side's image
// (panorama.json's image, read from its header when image_size is absent), not of "dimension" or of another
// image that happens to lie beside the JSON.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "ground/adjust/DatasetNetwork.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/io/CameraFile.hpp"
#include "tests/firmware_core/camera/TestModels.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

Network g_dataset_net;

void writePgm(const std::string& path, int w, int h) {
  std::ofstream f(path, std::ios::binary);
  f << "P5\n" << w << " " << h << "\n255\n" << std::string(static_cast<std::size_t>(w) * h, '\x40');
}

std::string tuple(const Vec3& v) {
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, "(%.17g,%.17g,%.17g)", v.x(), v.y(), v.z());
  return buffer;
}

}  // namespace

TEST_GROUP(DatasetNetwork){};

TEST(DatasetNetwork, M2020ModelsTakeThePixelFrameOfTheDatasetImage) {
  const std::string root = test::scratchDir("dataset_network_m2020");
  std::filesystem::create_directories(root + "/images");
  std::filesystem::create_directories(root + "/models");
  // A full-resolution 5152 x 3872 CAHVOR (principal point 0.5 % / 0.7 % off centre).
  const CameraModel full = test::modelFromSpec({2960.0, 2961.0, 2590.0, 1950.0, 0.0005, 0.2, 0.9, -0.4,
                                                0.1 * M_PI / 180.0, Vec3(1e-6, 0.05, -0.017), 5152, 3872},
                                               Vec3(0.9, 0.3, -1.9));
  // The dataset's image is the 1/4 browse image; the JSON says 644 x 484 and a 644 x 484 PNG lies beside it.
  writePgm(root + "/images/L.pgm", 1288, 968);
  writePgm(root + "/models/L.pgm", 644, 484);
  std::ofstream(root + "/models/L-metadata.json")
      << "{\"camera_model_type\": \"CAHVOR\", \"camera_model_component_list\": \"" << tuple(full.c) << ";"
      << tuple(full.a) << ";" << tuple(full.h) << ";" << tuple(full.v) << ";" << tuple(full.o) << ";"
      << tuple(full.r)
      << "\", \"dimension\": \"(644,484)\", \"scale_factor\": 1, \"subframe_rect\": [1, 1, 644, 484]}";
  // Read alone, the file takes the image beside it: 1/8.
  DOUBLES_EQUAL(8.0, io::readCameraFile(root + "/models/L-metadata.json").scale, 0.0);

  Dataset dataset;
  dataset.root = root;
  Pair p;
  p.left = makeImageRef(root, "images/L.pgm", std::string("models/L-metadata.json"));
  dataset.pairs.push_back(p);
  ground::NetworkSource source;
  ground::buildNetwork(dataset, {}, ground::RigChoice{}, g_dataset_net, source);
  CHECK_EQUAL(1u, source.apriori_models.size());
  const CameraModel& m = source.apriori_models[0];
  CHECK_EQUAL(1288, m.width);
  CHECK_EQUAL(968, m.height);
  const CameraModel truth = io::rescaledModel(full, 4.0, Vec2(1.5, 1.5), 1288, 968);
  double worst = 0.0;
  for (int k = 0; k < 25; ++k) {
    const Vec2 pixel(1288.0 * (k % 5 + 0.5) / 5.0, 968.0 * (k / 5 + 0.5) / 5.0);
    Vec3 origin, dir;
    CHECK(unproject(truth, pixel, origin, dir) == Status::kOk);
    Vec2 back;
    CHECK(project(m, origin + 7.0 * dir, back) == Status::kOk);
    worst = std::fmax(worst, (back - pixel).norm());
  }
  std::printf("\ndataset image 1288 x 968, JSON dimension 644 x 484: a-priori model %d x %d, worst %.1e px\n",
              m.width, m.height, worst);
  CHECK(worst < 1e-6);
}
