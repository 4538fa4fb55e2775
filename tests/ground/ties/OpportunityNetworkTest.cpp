// The automatic tie points and the constrained adjustment on every real frame that can form a network, with
// bounds that follow from the data and the adjustment's own statistics.
//
// Which real frames: of ../shared/data, only mer-opportunity-navcam-sol4087 holds overlapping real images
// with camera models (two Navcam-left frames of one mast position, ~200 px overlap). The Spirit Navcam rig
// (mer-spirit-navcam-sol767-labels) has its models but no pixels, the Perseverance frame is a single image,
// Middlebury has no camera models: none of them can give a tie point. So the network is two mono frames
// under the gimbal constraint (Eq. 3); there is no stereo base (Eq. 4) to hold and no stereo pair to
// triangulate from alone, hence no method 2 or 3: the held-out check below is made by 2-ray triangulation.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "firmware_core/adjust/Precision.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/ties/TieAdjust.hpp"
#include "ground/ties/TieRunner.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

// Upper quantile q of (chi2(a) / a) / (chi2(b) / b), b = 0 meaning chi2(a) / a alone: a deterministic Monte
// Carlo (fixed seed, 200 000 draws; the quantile is good to ~1 % at q = 0.995), so that the bounds below
// come from the degrees of freedom of this run rather than from a table.
double varianceRatioQuantile(int a, int b, double q) {
  std::mt19937_64 rng(20240611);
  std::chi_squared_distribution<double> ca(a);
  std::chi_squared_distribution<double> cb(b > 0 ? b : 1);
  std::vector<double> draws(200000);
  for (double& d : draws) d = (ca(rng) / a) / (b > 0 ? cb(rng) / b : 1.0);
  const std::size_t k = static_cast<std::size_t>(q * static_cast<double>(draws.size()));
  std::nth_element(draws.begin(), draws.begin() + static_cast<std::ptrdiff_t>(k), draws.end());
  return draws[k];
}

// The two frames as a dataset, their tie points, and the network with the rig constraints set.
struct OpportunityNetwork {
  Dataset dataset;
  TieNetwork network;
  TieRun run;
};

void makeNetwork(const std::string& root, OpportunityNetwork& on) {
  on.dataset.root = root;
  for (const char* image : {"1N491020376ILFCNY9P0706L0M1.IMG", "1N491020519ILFCNY9P0706L0M1.IMG"}) {
    Pair p;
    p.id = static_cast<int>(on.dataset.pairs.size());
    p.sol = 4087;
    p.left = makeImageRef(root, image);
    on.dataset.pairs.push_back(p);
  }
  on.run = runTiePoints(io::loadPanorama(on.dataset), false, &on.network);
  std::vector<std::string> notes;
  setRigConstraints(on.dataset, on.network.sol_of_index, *on.network.net, notes);
}

// Largest |C - XG - M^T c| over the images (Eq. 3), computed here from the network's cameras and rig.
double largestGimbalMisfit(const Network& net) {
  double worst = 0.0;
  for (int32_t i = 0; i < net.imageCount(); ++i) {
    const NetImage& im = net.image(i);
    const Vec3& offset = im.side == Side::kLeft ? net.rig.left_offset_m : net.rig.right_offset_m;
    const Vec3 g = im.centre_m - net.rig.gimbal_m[im.sol] - im.m.transpose() * offset;
    worst = std::max(worst, g.norm());
  }
  return worst;
}

// A point triangulated from its observations in the current cameras (observations flagged rejected are
// taken back first), and its whitened back-projection residuals: the sum of squares over its observations.
// False when the rays do not fix it.
bool heldOutCost(Network& net, int32_t point, double& cost) {
  const NetPoint& pt = net.point(point);
  for (int32_t k = 0; k < pt.obs_count; ++k) net.observation(pt.obs[k]).rejected = false;
  if (!ok(net.triangulate(point))) return false;
  cost = 0.0;
  for (int32_t k = 0; k < pt.obs_count; ++k) {
    const NetObservation& o = net.observation(pt.obs[k]);
    const NetImage& im = net.image(o.image);
    Vec2 pixel;
    if (!ok(collinearity(im.io, im.centre_m, im.m, pt.xyz_m, pixel))) return false;
    cost += (o.ideal_px - pixel).squaredNorm() / (o.sigma_px * o.sigma_px);
  }
  return true;
}

}  // namespace

TEST_GROUP(OpportunityNetwork){};

// All ties in the adjustment: a redundant network, sigma0 and the residual RMS within what the stated
// observation sigma allows, the gimbal constraint held. Then half of the points held out: the cameras
// adjusted on the other half predict them as well as the adjustment's own residuals say they should.
TEST(OpportunityNetwork, RedundantAdjustmentMeetsItsStatisticsOnHeldOutTies) {
  const std::string folder = "mer-opportunity-navcam-sol4087";
  if (!test::requireSharedData(folder)) return;
  OpportunityNetwork on;
  makeNetwork(test::sharedDataDir() + "/" + folder, on);
  Network& net = *on.network.net;
  CHECK_EQUAL(2, net.imageCount());
  CHECK(net.rig.use_gimbal);

  // 1. Every tie in the adjustment.
  const AdjustOutcome all = adjustNetwork(net, FastAdjustOptions{});
  const FastAdjustResult& r = all.result;
  CHECK(ok(r.status));
  std::vector<int32_t> solvable;
  for (int32_t p = 0; p < net.pointCount(); ++p) {
    if (net.point(p).solvable) solvable.push_back(p);
  }
  const int32_t n_points = static_cast<int32_t>(solvable.size());
  // Redundancy counted independently: 2 coordinates per active observation, 3 gimbal rows per image, less
  // 6 EO unknowns per image and 3 per solvable point, plus the 3 datum rotations the weak prior fixes (it is
  // not counted as observations). It must be positive for sigma0 to mean anything.
  const int32_t redundancy =
      2 * r.active_observations + 3 * net.imageCount() - 6 * net.imageCount() - 3 * n_points + 3;
  const double sigma_px = net.observation(0).sigma_px;  // the a-priori sigma the pipeline gives every tie
  const double sigma0_upper = std::sqrt(varianceRatioQuantile(r.redundancy, 0, 0.995));
  // Per-coordinate RMS of the residuals of a least-squares fit: sigma * sigma0 * sqrt(r / n), n the
  // coordinates; the chi-square quantile of sigma0 gives its bound.
  const int32_t coordinates = 2 * r.active_observations;
  const double rms_upper_px =
      sigma_px * sigma0_upper * std::sqrt(static_cast<double>(r.redundancy) / coordinates);
  std::printf(
      "opportunity network: %d points (%d solvable), %d active observations, redundancy %d; sigma0 %.3f "
      "(upper bound %.3f at sigma %.2f px: the ties' implied precision %.3f px); residual RMS %.4f px "
      "(bound %.4f px); method 1 %.3f -> %.3f px; gimbal misfit %.2e m\n",
      net.pointCount(), n_points, r.active_observations, r.redundancy, r.sigma0, sigma0_upper, sigma_px,
      r.sigma0 * sigma_px, r.rms_px, rms_upper_px, all.before.dist, all.after.dist, largestGimbalMisfit(net));
  CHECK_EQUAL(redundancy, r.redundancy);
  CHECK(r.redundancy > 0);
  // sigma0^2 = cost / r is chi2(r) / r when the weights are right: above its 99.5 % quantile the ties are
  // worse than the sigma the pipeline gives them. (Below 1 means they are better: here sigma0 ~0.3, i.e. the
  // 0.3 px a-priori sigma is ~3x pessimistic for these frames, which the bound allows.)
  CHECK(r.sigma0 <= sigma0_upper);
  CHECK(r.rms_px <= rms_upper_px);
  // Every image's EO got its a-posteriori sigmas (a rigid network: the covariance exists).
  CHECK(ok(r.covariance_status));
  for (int32_t i = 0; i < net.imageCount(); ++i) CHECK(net.image(i).sigma.minCoeff() > 0.0);
  // The gimbal constraint is held (no sigma in the dataset): every camera centre within kRigMisfitBound_m
  // of where Eq. 3 puts it, measured here from the adjusted cameras.
  CHECK(r.held_rig_met);
  CHECK(largestGimbalMisfit(net) <= kRigMisfitBound_m);

  // 2. Held out: every other solvable point (they alternate across the overlap). The adjustment on the rest
  // starts from the a-priori cameras. The relative rotation of the two frames is what the ties determine
  // (the centres are fixed by Eq. 3, the common rotation by the datum prior), so each half must over-
  // determine those 3 unknowns on its own.
  CHECK(n_points >= 8);
  net.resetToApriori();
  std::vector<int32_t> held;
  for (std::size_t k = 1; k < solvable.size(); k += 2) held.push_back(solvable[k]);
  // The held-out points as the a-priori cameras see them (heldOutCost takes their observations back; they
  // are flagged out again for the training adjustment).
  double held_cost_apriori = 0.0;
  for (int32_t p : held) {
    double c = 0.0;
    CHECK(heldOutCost(net, p, c));
    held_cost_apriori += c;
    const NetPoint& pt = net.point(p);
    for (int32_t k = 0; k < pt.obs_count; ++k) net.observation(pt.obs[k]).rejected = true;
  }
  const AdjustOutcome train = adjustNetwork(net, FastAdjustOptions{});
  CHECK(ok(train.result.status));
  CHECK(train.result.redundancy > 0);
  CHECK(largestGimbalMisfit(net) <= kRigMisfitBound_m);
  double held_cost = 0.0;
  for (int32_t p : held) {
    double c = 0.0;
    CHECK(heldOutCost(net, p, c));
    held_cost += c;
  }
  // Each held-out point has 4 coordinates and 3 unknowns: 1 degree of freedom, so held_cost / n_held
  // estimates the same variance factor as sigma0^2 of the training adjustment; their ratio is F(n_held,
  // r_train) distributed, widened by the held-out point's share of the relative-rotation error (its
  // prediction variance is sigma^2 (1 + h); h ~ 3 unknowns / training points on average, taken twice).
  const int32_t n_held = static_cast<int32_t>(held.size());
  const int32_t n_train = n_points - n_held;
  const double ratio = (held_cost / n_held) / (train.result.sigma0 * train.result.sigma0);
  const double ratio_upper =
      varianceRatioQuantile(n_held, train.result.redundancy, 0.995) * (1.0 + 2.0 * 3.0 / n_train);
  std::printf(
      "held out %d points, trained on %d (redundancy %d, sigma0 %.3f): held-out variance factor %.3f "
      "(a-priori cameras %.1f), ratio to the training's %.2f, bound %.2f\n",
      n_held, n_train, train.result.redundancy, train.result.sigma0, held_cost / n_held,
      held_cost_apriori / n_held, ratio, ratio_upper);
  CHECK(ratio <= ratio_upper);
  // And the adjusted cameras predict the held-out ties better than the a-priori pointing does. (With 14
  // solvable ties the training half keeps a redundancy of 4, and the F bound is too wide to tell the two
  // apart by itself: the a-priori cameras' ratio, ~23, is also below it.)
  CHECK(held_cost < held_cost_apriori);
}
