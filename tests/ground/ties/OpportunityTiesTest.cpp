#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "ground/dataset/Dataset.hpp"
#include "ground/ties/TieAdjust.hpp"
#include "ground/ties/TieRunner.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

TEST_GROUP(OpportunityTies){};

// Two real Opportunity Navcam-left frames of one mast position (~200 px overlap, models from the PDS3
// labels): tie points are found in the overlap, and adjusting the two frames' pointing under the gimbal
// constraint lowers the back-projection residual (the paper reached 0.80 px).
TEST(OpportunityTies, TiesInTheOverlapAndTheAdjustmentLowersTheResidual) {
  const std::string folder = "mer-opportunity-navcam-sol4087";
  if (!test::requireSharedData(folder)) return;
  Dataset dataset;
  dataset.root = test::sharedDataDir() + "/" + folder;
  for (const char* image : {"1N491020376ILFCNY9P0706L0M1.IMG", "1N491020519ILFCNY9P0706L0M1.IMG"}) {
    Pair p;
    p.id = static_cast<int>(dataset.pairs.size());
    p.sol = 4087;
    p.left = makeImageRef(dataset.root, image);
    dataset.pairs.push_back(p);
  }
  TieNetwork network;
  const TieRun run = runTiePoints(io::loadPanorama(dataset), false, &network);
  // Every observation is an inter-image tie, and on each frame they lie in the strip the other one sees.
  double min_x[2] = {1e9, 1e9}, max_x[2] = {-1e9, -1e9};
  int per_image[2] = {0, 0};
  for (const ImageObservation& o : run.observations) {
    const int k = o.image == run.stems[0] ? 0 : 1;
    ++per_image[k];
    min_x[k] = std::fmin(min_x[k], o.sample_px);
    max_x[k] = std::fmax(max_x[k], o.sample_px);
    CHECK_EQUAL(std::string("inter"), o.kind);
  }
  std::printf("opportunity: %zu tie points; frame 0 samples %.0f..%.0f, frame 1 samples %.0f..%.0f\n",
              run.points_m.size(), min_x[0], max_x[0], min_x[1], max_x[1]);
  CHECK(run.points_m.size() >= 10);
  CHECK_EQUAL(per_image[0], per_image[1]);
  // The overlap is one side strip of each frame (~200 px of 1024): the ties span less than 40 % of the width.
  for (int k = 0; k < 2; ++k) CHECK(max_x[k] - min_x[k] < 0.4 * 1024);

  std::vector<std::string> notes;
  setRigConstraints(dataset, network.sol_of_index, *network.net, notes);
  const AdjustOutcome o = adjustNetwork(*network.net, FastAdjustOptions{});
  std::printf("opportunity adjustment (gimbal constraint, %s): method 1 (x, y, dist) before (%.2f, %.2f, %.2f) px, "
              "after (%.2f, %.2f, %.2f) px; %s, %d sweeps, %d rejected (paper: 0.80 px)\n",
              notes.empty() ? "rig given" : notes.front().c_str(), o.before.x, o.before.y, o.before.dist, o.after.x,
              o.after.y, o.after.dist, statusName(o.result.status), o.result.sweeps_total,
              o.result.rejected_observations);
  CHECK(ok(o.result.status));
  CHECK(network.net->rig.use_gimbal);
  CHECK(o.after.dist < o.before.dist);
}
