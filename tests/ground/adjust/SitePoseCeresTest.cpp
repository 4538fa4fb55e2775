// The Ceres formulation of the multi-site adjustment (ground/adjust/SitePoseCeres.hpp) against the
// firmware's SitePoseAdjuster on the same 5-site traverses, so that the comparison of
// ground_site_pose_bench cannot rot: the two formulations give the same cost at the same state, and reach
// the same solution from the same start (least squares; the Huber solve and the firmware's rejections;
// a sliding window with held sites).
#include <cstdio>
#include <memory>

#include "ground/adjust/SitePoseCeres.hpp"
#include "tests/firmware_core/adjust/SyntheticTraverse.hpp"

#include <CppUTest/TestHarness.h>

namespace {

using namespace areomap;

// A 5-site traverse loaded from its a-priori chain and adjusted by the firmware.
void adjustFiveSites(double outliers, const SitePoseOptions& options, GroundSitePoseAdjuster& adjuster,
                     SitePoseResult& r) {
  test::TraverseConfig cfg;
  cfg.sites = 5;
  cfg.seed = 1;
  cfg.outlier_fraction = outliers;
  const test::TraversePlan plan = test::makeTraversePlan(cfg);
  test::TraverseLoad load;
  CHECK(test::loadTraverse(plan, 0, 5, true, adjuster, load));
  CHECK(ok(adjuster.adjust(options, r)));
  CHECK(r.converged);
}

// Ceres' solution is the firmware's: the same observations, cost, poses and points.
void checkSameSolution(const char* what, const GroundSitePoseAdjuster& adjuster, const SitePoseResult& r,
                       const ground::SitePoseProblem& problem, const ground::SitePoseCeresResult& c) {
  CHECK(c.converged);
  CHECK_EQUAL(r.active_observations, c.observations);
  CHECK_EQUAL(r.solvable_points, c.points);
  const ground::SitePoseDifference d = ground::sitePoseDifference(adjuster, problem);
  std::printf(
      "\n  5 sites, %s: cost firmware %.9f, Ceres %.9f; max |ceres - firmware| %.2e m, %.2e rad, points "
      "%.2e m; iterations %d / %d\n",
      what, r.cost, c.cost, d.position_m, d.rotation_rad, d.point_m, r.iterations_total, c.iterations);
  DOUBLES_EQUAL(c.cost, r.cost, 1e-8 * c.cost);
  // Largest seen (x86-64): 2.5e-6 m, 1e-8 rad, points 7.5e-6 m, in the cold window; a formulation that
  // differs (a row, a weight, the datum) moves them by millimetres or more.
  CHECK(d.position_m < 2e-5);
  CHECK(d.rotation_rad < 1e-6);
  CHECK(d.point_m < 5e-5);
}

}  // namespace

TEST_GROUP(SitePoseCeres) {
  std::unique_ptr<GroundSitePoseAdjuster> adjuster;
  void setup() override {
    adjuster = std::make_unique<GroundSitePoseAdjuster>();
  }
  void teardown() override {
    adjuster.reset();
  }
};

TEST(SitePoseCeres, SameCostSameStartSameLeastSquaresSolution) {
  SitePoseOptions options;
  options.robust = false;
  SitePoseResult r;
  adjustFiveSites(0.0, options, *adjuster, r);
  // The firmware's start (the a-priori chain, its points placed as it placed them) by both formulations.
  ground::SitePoseProblem problem = ground::sitePoseProblemOf(*adjuster, 1, true, false);
  const double start_rows = ground::sitePoseRowsCost(problem, 0.0);
  DOUBLES_EQUAL(r.initial_cost, start_rows, 1e-9 * r.initial_cost);
  const ground::SitePoseCeresResult c = ground::solveSitePosesCeres(problem, ground::SitePoseCeresOptions{});
  DOUBLES_EQUAL(start_rows, c.initial_cost, 1e-9 * start_rows);
  CHECK_EQUAL(4, c.free_sites);
  // The same minimum, and the firmware's rows give Ceres' cost at Ceres' solution.
  DOUBLES_EQUAL(c.cost, ground::sitePoseRowsCost(problem, 0.0), 1e-9 * c.cost);
  checkSameSolution("least squares", *adjuster, r, problem, c);
}

TEST(SitePoseCeres, HuberSolveThenTheFirmwaresRejectionsReachTheFirmwaresSolution) {
  const SitePoseOptions defaults;
  SitePoseResult r;
  adjustFiveSites(0.05, defaults, *adjuster, r);
  CHECK(r.rejected_observations > 0);
  ground::SitePoseProblem problem = ground::sitePoseProblemOf(*adjuster, 1, true, false);
  ground::SitePoseCeresOptions options;
  options.huber_sigma = defaults.huber_sigma;
  const ground::SitePoseCeresResult huber = ground::solveSitePosesCeres(problem, options);
  // The Huber solve need not converge to Ceres' tight tolerances (it stopped at its 100-step bound,
  // 30 times closer to the inliers' minimum than the start); it is where the final solve starts. The two
  // formulations of the Huber cost agree at its end.
  std::printf("\n  %d rejected by the firmware; Ceres' Huber solve %d steps (%s)", r.rejected_observations,
              huber.iterations, huber.termination.c_str());
  CHECK(huber.cost < 0.1 * huber.initial_cost);
  DOUBLES_EQUAL(huber.cost, ground::sitePoseRowsCost(problem, defaults.huber_sigma), 1e-9 * huber.cost);
  for (int32_t o = 0; o < adjuster->observationCount(); ++o)
    problem.observations[o].rejected = adjuster->observation(o).rejected;
  options.huber_sigma = 0.0;
  const ground::SitePoseCeresResult c = ground::solveSitePosesCeres(problem, options);
  checkSameSolution("5 % gross errors, then the firmware's rejections", *adjuster, r, problem, c);
}

TEST(SitePoseCeres, WindowWithHeldSitesReachesTheFirmwaresSolution) {
  // A cold window: sites 1 and 2 held at their a-priori (odometry) poses, 3 and 4 free, so the ties to the
  // held sites pull hard (a large cost); what is checked is the window's rules in both formulations: held
  // sites constant, the leg between two held sites left out, points that only held sites see left out.
  SitePoseOptions options;
  options.robust = false;
  options.window_sites = 2;
  SitePoseResult r;
  adjustFiveSites(0.0, options, *adjuster, r);
  CHECK_EQUAL(3, r.first_free_site);
  ground::SitePoseProblem problem = ground::sitePoseProblemOf(*adjuster, r.first_free_site, true, false);
  const ground::SitePoseCeresResult c = ground::solveSitePosesCeres(problem, ground::SitePoseCeresOptions{});
  CHECK_EQUAL(2, c.free_sites);
  checkSameSolution("window of 2", *adjuster, r, problem, c);
  for (int32_t k = 0; k < r.first_free_site; ++k)
    CHECK((problem.poses[k].position_m - adjuster->site(k).pose.position_m).norm() == 0.0);
}
