#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/ties/TieAdjust.hpp"
#include "ground/ties/TieCheck.hpp"
#include "ground/ties/TieRunner.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

// The tiny simulated panorama (8 pairs), made once per process.
const std::string& tinyDataset() {
  static const std::string dir = test::makeTinyDataset("ties-tiny");
  CHECK(!dir.empty());
  return dir;
}

}  // namespace

TEST_GROUP(TiesOnSimulation){};

// >= 98 % of the observations within 1 px of the truth projection of the surface point their tie point
// claims; every adjacent pair linked by >= 10 tie points; the fast adjustment lowers method 1.
TEST(TiesOnSimulation, TiesMatchTheTruthLinkEveryAdjacentPairAndAdjust) {
  const Dataset dataset = readDataset(tinyDataset());
  TieNetwork network;
  const TieRun run = runTiePoints(io::loadPanorama(dataset), false, &network);
  const TieCheck c = checkTiesAgainstTruth(dataset, run);
  std::printf("tiny: %zu points, %d intra + %d inter observations; %.2f %% of %d within 1 px (inter %.2f %% of %d), "
              "rms %.3f px; %d adjacent pairs, weakest %s; %.2f s\n",
              run.points_m.size(), run.intra_observations, run.inter_observations,
              100.0 * c.within_1px / std::max(1, c.checked), c.checked,
              100.0 * c.inter_within_1px / std::max(1, c.inter_checked), c.inter_checked, c.rms_px, c.adjacent_pairs,
              c.worst_link.c_str(), run.seconds);
  CHECK(c.checked >= 500);
  CHECK(c.within_1px >= 0.98 * c.checked);
  CHECK(c.inter_checked >= 100);
  CHECK(c.inter_within_1px >= 0.98 * c.inter_checked);
  CHECK(c.adjacent_pairs >= 7);
  CHECK(c.min_link >= 10);
  CHECK_EQUAL(0, network.failed_observations);

  std::vector<std::string> notes;
  setRigConstraints(dataset, network.sol_of_index, *network.net, notes);
  const AdjustOutcome o = adjustNetwork(*network.net, FastAdjustOptions{});
  std::printf("tiny adjustment: method 1 mean distance %.3f px before, %.3f px after; %s, %d sweeps\n", o.before.dist,
              o.after.dist, statusName(o.result.status), o.result.sweeps_total);
  CHECK(ok(o.result.status));
  CHECK(o.after.dist < 0.5 * o.before.dist);
  CHECK(o.after.dist < 0.3);
}

TEST(TiesOnSimulation, ToolWritesTiePointsOverlaysAndReport) {
  const std::string out = test::scratchDir("ties-tool");
  CHECK_EQUAL(0, test::runTool("areomap-ties", tinyDataset() + " --out " + out + " --adjust"));
  const std::vector<ImageObservation> ties = readTiePointsCsv(out + "/tiepoints.csv");
  CHECK(ties.size() > 100);
  int intra = 0, inter = 0;
  for (const ImageObservation& o : ties) {
    intra += o.kind == "intra" ? 1 : 0;
    inter += o.kind == "inter" ? 1 : 0;
  }
  CHECK(intra > 0);
  CHECK(inter > 0);
  CHECK_EQUAL(static_cast<int>(ties.size()), intra + inter);
  CHECK(test::fileExists(out + "/overlays/p000_L.png"));
  CHECK(test::fileExists(out + "/overlays/p000_R.png"));
  CHECK(test::fileExists(out + "/models/p000_L.cahvor"));
  CHECK(test::fileExists(out + "/report.json"));
  // Exit codes: usage 2, bad dataset 1, help 0.
  CHECK_EQUAL(2, test::runTool("areomap-ties", tinyDataset()));
  CHECK_EQUAL(2, test::runTool("areomap-ties", "--out " + out));
  CHECK_EQUAL(1, test::runTool("areomap-ties", out + "/no-such-dataset --out " + out));
  CHECK_EQUAL(0, test::runTool("areomap-ties", "--help"));
}
