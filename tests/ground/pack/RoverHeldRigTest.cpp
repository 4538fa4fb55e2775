// The rover side of the held rig sigmas (firmware_core/adjust/Network.hpp): a dataset whose panorama.json
// gives no constraint sigmas is packed (sigmas_given false, the starting sigma in the stream) and fed to the
// rover node; its final network must hold Eq. 3 and Eq. 4 to 0.1 mm, as the ground's adjusters do, while the
// same stream with the former defaults given explicitly (1 mm / 0.5 mm) is adjusted with those sigmas.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "firmware_core/adjust/Constraints.hpp"
#include "firmware_core/adjust/Datum.hpp"
#include "firmware_core/node/RoverNode.hpp"
#include "ground/adjust/DatasetNetwork.hpp"
#include "ground/dataset/Dataset.hpp"
#include "tests/ground/pack/TinyStream.hpp"
#include "tests/support/TestData.hpp"

// Includes CppUTest: after every STL, Eigen and OpenCV header.
#include "tests/ground/pack/RoverHarness.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

RoverNode& heldRigRover() {
  return test::harnessRover();
}

// Every event of the stream straight into the node (its publications go to a memory outbox nobody reads).
void runHeldRigRover(const std::vector<LogEvent>& events) {
  (void)test::feedRover(events, [](platform::MemoryTransport&) {});
  CHECK(heldRigRover().counters().finished);
}

// The rover's final EO against the dataset's true models (datum removed), pixel equivalent at 5 m.
double roverEoError(const Dataset& dataset) {
  const Network& net = heldRigRover().network();
  ground::NetworkSource source;
  for (int32_t i = 0; i < net.imageCount(); ++i) source.stems.push_back(heldRigRover().stemOfImage(i));
  const ground::NetworkTruth truth = ground::loadNetworkTruth(dataset, source, false);
  CHECK(truth.available);
  return truthErrors(net, truth.centres.data(), truth.rotations.data(), nullptr, net.rig.gimbal_m[0], true,
                     5.0)
      .eo_px;
}

}  // namespace

TEST_GROUP(RoverHeldRig){};

TEST(RoverHeldRig, RoverHoldsTheConstraintsOfADatasetWithoutSigmas) {
  const std::string dir = test::scratchDir("rover-held-rig") + "/sim";
  CHECK_EQUAL(0, test::runTool("areomap-sim",
                               "--preset tiny --seed 3 --base-m 0.3 --fov-deg 50 --threads 2 --out " + dir));
  Dataset d = readDataset(dir);
  double misfit[2] = {};
  double eo[2] = {};
  for (int k = 0; k < 2; ++k) {
    d.rig.sigma_gimbal_m.reset();
    d.rig.sigma_base_m.reset();
    if (k == 1) {
      d.rig.sigma_gimbal_m = 1e-3;
      d.rig.sigma_base_m = 5e-4;
    }
    writeDataset(d, dir);
    runHeldRigRover(test::packedStream(dir));
    const Network& net = heldRigRover().network();
    const ConstraintMisfit m = networkMisfit(net);
    misfit[k] = std::fmax(m.gimbal_m, m.base_m);
    eo[k] = roverEoError(readDataset(dir));
    std::printf(
        "\n  rover, %s: %d images, %d points, hold %d/%d, sigmas %.2e / %.2e m, misfit gimbal %.4f mm base "
        "%.4f mm, EO vs truth %.4f px, rms %.4f px\n",
        k == 0 ? "no sigmas in panorama.json" : "sigmas 1 mm / 0.5 mm given", net.imageCount(),
        net.pointCount(), net.rig.hold_gimbal, net.rig.hold_base, net.rig.sigma_gimbal_m,
        net.rig.sigma_base_m, m.gimbal_m * 1e3, m.base_m * 1e3, eo[k], heldRigRover().counters().last_rms_px);
    CHECK(m.base_m > 0.0);
    if (k == 0) {
      CHECK(net.rig.hold_gimbal && net.rig.hold_base);
    } else {
      CHECK(!net.rig.hold_gimbal && !net.rig.hold_base);
      DOUBLES_EQUAL(1e-3, net.rig.sigma_gimbal_m, 0.0);
      DOUBLES_EQUAL(5e-4, net.rig.sigma_base_m, 0.0);
    }
  }
  CHECK(misfit[0] <= kRigMisfitBound_m);
  CHECK(misfit[1] > kRigMisfitBound_m);
  CHECK(eo[0] <= eo[1] + 0.01);
}
