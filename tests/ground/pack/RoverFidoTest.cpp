// The rover side of the automatic FIDO model (firmware_core/adjust/RigShape.hpp): areomap-sim --preset fido
// (tilt axis 10 cm ahead of the pan axis; 3 pairs per tier of 256 x 256 on a coarser terrain, as
// tests/ground/ties/FidoTiesTest.cpp) packed as areomap-pack does and fed to the rover node, whose stream
// carries Eq. 3 values fitted by the packer: the node must switch to the FIDO model at its adjustment from
// the a-priori cameras it has, with zero heap in the pipeline, and correct the a-priori pointing; the same
// scene with the axes meeting (--tilt-axis-forward-m 0) must stay with Eq. 3. On the FIDO mast the rover's
// EO error over its covariance's prediction is within a factor 2 of the gimbal rig's (at least 1).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

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

struct RoverFidoRun {
  bool fido = false;
  uint64_t allocations = 0;
  double eo_before_px = 0.0;
  double eo_after_px = 0.0;
  double predicted_px = 0.0;
};

// The rover's final network against the true models (datum removed), pixel equivalent at 5 m, and what the
// adjustment's covariance predicts in the same measure.
RoverFidoRun roverOnScene(const std::string& sim_args, const char* name) {
  const std::string dir = test::scratchDir(std::string("rover-fido-") + name) + "/sim";
  CHECK_EQUAL(0, test::runTool("areomap-sim", sim_args + " --out " + dir));
  RoverFidoRun out;
  out.allocations = test::feedRover(test::packedStream(dir), [](platform::MemoryTransport&) {});
  RoverNode& rover = test::harnessRover();
  CHECK(rover.counters().finished);
  out.fido = rover.counters().fido_model;
  // A copy (several MiB, on the heap outside the pipeline) to compare its a-priori cameras as well.
  auto net = std::make_unique<Network>(rover.network());
  CHECK(net->rig.use_gimbal);  // Eq. 3 either way: with the mast's tilt arm on the FIDO mast
  CHECK_EQUAL(out.fido, net->rig.use_tilt_arm);
  CHECK(!net->rig.use_spin_centre);
  ground::NetworkSource source;
  for (int32_t i = 0; i < net->imageCount(); ++i) source.stems.push_back(rover.stemOfImage(i));
  const ground::NetworkTruth truth = ground::loadNetworkTruth(readDataset(dir), source, false);
  CHECK(truth.available);
  const auto eoError = [&] {
    return truthErrors(*net, truth.centres.data(), truth.rotations.data(), nullptr, net->rig.gimbal_m[0], true,
                       5.0)
        .eo_px;
  };
  out.eo_after_px = eoError();
  double sum = 0.0;
  for (int32_t i = 0; i < net->imageCount(); ++i) {
    const NetImage& im = net->image(i);
    const double px = im.io.f_px * (im.sigma.tail<3>().norm() + im.sigma.head<3>().norm() / 5.0);
    sum += px * px;
  }
  out.predicted_px = std::sqrt(sum / std::max(1, net->imageCount()));
  net->resetToApriori();
  out.eo_before_px = eoError();
  std::printf("\n  rover %s: %s (Eq. 3 fit %.3f mm RMS), EO vs truth %.2f -> %.3f px, covariance %.3f px, "
              "pipeline heap %llu",
              name, out.fido ? "FIDO" : "gimbal", rover.counters().rig_fit_rms_m * 1000.0, out.eo_before_px,
              out.eo_after_px, out.predicted_px, static_cast<unsigned long long>(out.allocations));
  return out;
}

}  // namespace

TEST_GROUP(RoverFido){};

TEST(RoverFido, TheNodeSwitchesToTheFidoModelOnAnOffsetTiltAxisWithoutHeap) {
  const std::string scene =
      "--preset fido --pairs 6 --size 256 256 --cell-m 0.05 --supersample 1 --extent-m 15 --range-m 1.5 14 "
      "--threads 2 --seed 8";
  const RoverFidoRun fido = roverOnScene(scene, "offset-tilt-axis");
  const RoverFidoRun gimbal = roverOnScene(scene + " --tilt-axis-forward-m 0", "axes-meet");
  CHECK(fido.fido);
  CHECK(!gimbal.fido);
  for (const RoverFidoRun* r : {&fido, &gimbal}) {
    if (heapCounterActive()) CHECK_EQUAL(0u, r->allocations);
    CHECK(r->eo_after_px < r->eo_before_px / 3.0);
  }
  // As accurate as the gimbal rig relative to the covariance (the criterion of FidoTiesTest.cpp).
  const double fido_ratio = fido.eo_after_px / fido.predicted_px;
  const double gimbal_ratio = gimbal.eo_after_px / gimbal.predicted_px;
  CHECK(fido_ratio < 2.0 * std::fmax(1.0, gimbal_ratio));
}
