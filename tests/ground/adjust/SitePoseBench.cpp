// ground_site_pose_bench: the multi-site (traverse) adjustment (firmware_core/adjust/SitePoseAdjuster.hpp)
// against the number of sites and against Ceres on the same problem, side by side in one process.
//
// Per number of sites N: one synthetic traverse of the site-pose adjuster's tests
// (tests/firmware_core/adjust/SyntheticTraverse.hpp with its defaults: a winding path of sites 10-30 m
// apart, a ring of 10 stereo pairs per site, 40 ground points between neighbouring sites seen by every site
// within 25 m, 0.3 px noise, odometry 5 % of the leg and 2 deg of heading), solved
//   (a) by the ground's GroundSitePoseAdjuster over the whole traverse from the a-priori chain, default
//       options (Huber solve, rejection rounds, the final least-squares solve, the sites' covariance), and
//       the same without the covariance (the solve alone, the figure Ceres is compared with);
//   (b) by the rover's SitePoseAdjuster in its sliding window (the last K sites free), the sites added one
//       by one with the warm start, one adjust() per added site (the ground instance beyond kMaxSites);
//   (c) by Ceres on the same problem (ground/adjust/SitePoseCeres.hpp: the same unknowns, rows, datum,
//       start and points): a first solve under the same Huber loss, then the least-squares solve over the
//       observations the firmware kept (its rejection flags), from the Huber solution.
// Every time is the median and the best of --repeat rounds (each round runs every method once, after one
// untimed round); the heap allocations of the firmware's adjust() are counted (its thread's).
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "ground/adjust/SitePoseCeres.hpp"
#include "ground/cli/Cli.hpp"
#include "platform/heap/HeapCounter.hpp"
#include "tests/firmware_core/adjust/SyntheticTraverse.hpp"

namespace {

using namespace areomap;
using Clock = std::chrono::steady_clock;

const char* kUsage =
    "usage: ground_site_pose_bench [--sites 5,10,20] [--repeat 5] [--window 4] [--outliers F] [--seed S]\n"
    "Prints markdown tables: per number of sites, the firmware's full and windowed solves and Ceres on the\n"
    "same problem (time, iterations, cost, position error vs truth) and their agreement.\n";

SitePoseAdjuster g_rover;  // the rover's: a static object

double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Seconds over the rounds: the median, and the best (the least disturbed by the other jobs of the machine).
struct Timing {
  double median = -1.0;
  double best = -1.0;
};

Timing timing(const std::vector<double>& seconds) {
  return {median(seconds), *std::min_element(seconds.begin(), seconds.end())};
}

// RMS over the sites after site 0 (the datum, at its true pose) of the position error against the truth.
double positionRms(const std::vector<TraverseFromSite>& poses, const std::vector<TraverseFromSite>& truth) {
  double sq = 0.0;
  for (size_t k = 1; k < poses.size(); ++k) sq += (poses[k].position_m - truth[k].position_m).squaredNorm();
  return poses.size() > 1 ? std::sqrt(sq / static_cast<double>(poses.size() - 1)) : 0.0;
}

template <typename Adjuster>
std::vector<TraverseFromSite> posesOf(const Adjuster& a, bool apriori) {
  std::vector<TraverseFromSite> poses;
  for (int32_t k = 0; k < a.siteCount(); ++k) poses.push_back(apriori ? a.site(k).apriori : a.site(k).pose);
  return poses;
}

struct Row {
  std::string solver;
  Timing time;
  std::string iterations;
  double cost = -1.0;
  double position_rms_m = -1.0;
  std::string note;
};

// One row; the times against `reference` (the firmware's solve alone), median to median and best to best.
void printRow(const std::string& problem, const Row& r, const Timing& reference) {
  char seconds[64] = "-", ratio[64] = "-", cost[32] = "-", rms[32] = "-";
  if (r.time.median >= 0.0) {
    std::snprintf(seconds, sizeof seconds, "%.5f / %.5f", r.time.median, r.time.best);
    std::snprintf(ratio, sizeof ratio, "%.2f / %.2f", r.time.median / reference.median,
                  r.time.best / reference.best);
  }
  if (r.cost >= 0.0) std::snprintf(cost, sizeof cost, "%.4f", r.cost);
  if (r.position_rms_m >= 0.0) std::snprintf(rms, sizeof rms, "%.4f", r.position_rms_m);
  std::printf("| %s | %s | %s | %s | %s | %s | %s | %s |\n", problem.c_str(), r.solver.c_str(), seconds,
              ratio, r.iterations.empty() ? "-" : r.iterations.c_str(), cost, rms, r.note.c_str());
}

// The firmware's solve of the whole traverse from the a-priori chain; returns its seconds.
double firmwareFull(GroundSitePoseAdjuster& adjuster, const SitePoseOptions& options, SitePoseResult& result,
                    uint64_t& heap_allocations) {
  adjuster.resetToApriori();
  const uint64_t heap0 = heapAllocationCountThisThread();
  const auto t0 = Clock::now();
  const Status s = adjuster.adjust(options, result);
  const double t = since(t0);
  heap_allocations = heapAllocationCountThisThread() - heap0;
  if (!ok(s)) throw cli::InputError("synthetic traverse", "adjust", statusName(s));
  return t;
}

// Rejections against the generator's gross errors: good observations rejected, gross ones caught.
struct Rejections {
  int32_t false_rejections = 0;
  int32_t caught = 0;
};

template <typename Adjuster>
Rejections rejectionsOf(const Adjuster& adjuster, const test::TraversePlan& plan,
                        const test::TraverseLoad& load) {
  Rejections r;
  for (std::size_t i = 0; i < plan.observations.size() && i < load.observation.size(); ++i) {
    if (load.observation[i] < 0 || !adjuster.observation(load.observation[i]).rejected) continue;
    if (plan.observations[i].outlier)
      ++r.caught;
    else
      ++r.false_rejections;
  }
  return r;
}

struct WindowRun {
  std::vector<double> seconds;  // per added site (sites 1 .. N-1)
  int32_t iterations = 0;       // over all adds
  int32_t rejected = 0;
  uint64_t heap_allocations = 0;
  double position_rms_m = 0.0;  // after the last add
  Rejections rejections;        // after the last add
};

// The rover's use: site 0 and 1 loaded, then one site after the other, each followed by adjust() of the
// last `window` sites.
template <typename Adjuster>
WindowRun firmwareWindow(const test::TraversePlan& plan, int32_t window, Adjuster& adjuster) {
  const int32_t sites = static_cast<int32_t>(plan.truth.size());
  SitePoseOptions options;
  options.window_sites = window;
  WindowRun run;
  test::TraverseLoad load;
  for (int32_t k = 1; k < sites; ++k) {
    const bool loaded = k == 1 ? test::loadTraverse(plan, 0, 2, true, adjuster, load)
                               : test::loadTraverse(plan, k, k + 1, false, adjuster, load);
    if (!loaded) throw cli::InputError("synthetic traverse", "load", "refused by the adjuster");
    SitePoseResult result;
    const uint64_t heap0 = heapAllocationCountThisThread();
    const auto t0 = Clock::now();
    const Status s = adjuster.adjust(options, result);
    const double t = since(t0);
    run.heap_allocations += heapAllocationCountThisThread() - heap0;
    run.seconds.push_back(t);
    if (!ok(s)) throw cli::InputError("synthetic traverse", "windowed adjust", statusName(s));
    run.iterations += result.iterations_total;
    run.rejected += result.rejected_observations;
  }
  run.position_rms_m = positionRms(posesOf(adjuster, false), plan.truth);
  run.rejections = rejectionsOf(adjuster, plan, load);
  return run;
}

struct CeresRun {
  ground::SitePoseProblem problem;
  ground::SitePoseCeresResult huber, final;
  double seconds = 0.0;  // both solves
};

// The norm of the parameter vector Ceres sees (positions, unit quaternions, points): its relative
// parameter tolerance is a step of tolerance x (|x| + tolerance).
double parameterNorm(const ground::SitePoseProblem& p) {
  double sq = static_cast<double>(p.poses.size());
  for (const TraverseFromSite& pose : p.poses) sq += pose.position_m.squaredNorm();
  for (size_t i = 0; i < p.points.size(); ++i) sq += p.placed[i] ? p.points[i].squaredNorm() : 0.0;
  return std::sqrt(sq);
}

// Ceres on the adjuster's problem from the firmware's start: the Huber solve over every observation, then
// the least-squares solve over the ones the firmware kept. `comparable`: the firmware's stop rules in
// Ceres' terms (the Huber solve at most 15 iterations and stopped at a 1 mm step, SitePoseAdjuster.cpp; the
// final solve at the relative cost decrease and the step of SitePoseOptions), else Ceres' tight defaults of
// SitePoseCeresOptions (the minimum to rounding).
CeresRun ceresRun(const GroundSitePoseAdjuster& adjuster, const SitePoseOptions& firmware, bool dense,
                  bool comparable) {
  CeresRun run;
  run.problem = ground::sitePoseProblemOf(adjuster, 1, true, false);
  const double norm = parameterNorm(run.problem);
  ground::SitePoseCeresOptions options;
  options.dense_schur = dense;
  options.huber_sigma = firmware.huber_sigma;
  if (comparable) {
    options.max_iterations = 15;
    options.function_tolerance = firmware.relative_cost_tolerance;
    options.gradient_tolerance = 1e-10;
    options.parameter_tolerance = 1e-3 / norm;
  }
  run.huber = ground::solveSitePosesCeres(run.problem, options);
  for (int32_t o = 0; o < adjuster.observationCount(); ++o)
    run.problem.observations[o].rejected = adjuster.observation(o).rejected;
  options.huber_sigma = 0.0;
  if (comparable) {
    options.max_iterations = firmware.max_iterations;
    options.parameter_tolerance = firmware.step_tolerance_m / norm;
  }
  run.final = ground::solveSitePosesCeres(run.problem, options);
  run.seconds = run.huber.seconds + run.final.seconds;
  return run;
}

void benchSites(int32_t sites, int repeat, int32_t window, double outliers, uint32_t seed) {
  test::TraverseConfig cfg;
  cfg.sites = sites;
  cfg.seed = seed;
  cfg.outlier_fraction = outliers;
  const test::TraversePlan plan = test::makeTraversePlan(cfg);
  int32_t gross = 0;
  for (const test::TraverseObservation& o : plan.observations) gross += o.outlier ? 1 : 0;
  double driven_m = 0.0;
  for (int32_t k = 1; k < sites; ++k)
    driven_m += (plan.truth[k].position_m - plan.truth[k - 1].position_m).norm();

  const auto ground = std::make_unique<GroundSitePoseAdjuster>();
  test::TraverseLoad load;
  if (!test::loadTraverse(plan, 0, sites, true, *ground, load))
    throw cli::InputError("synthetic traverse", "load", "refused by the ground's adjuster");
  const double apriori_rms = positionRms(posesOf(*ground, true), plan.truth);

  // One round: (a) the whole traverse, the solve alone and the default (with the covariance; the adjuster
  // keeps its solution and rejections); (c) Ceres from the same start, dense and sparse Schur, then tight;
  // (b) the sliding window, site by site. Rounds repeat so that every method sees the same load over the
  // run; each figure is the median over the rounds.
  SitePoseOptions solve_only;
  solve_only.covariance = false;
  const SitePoseOptions defaults;
  SitePoseResult solve_result, full_result;
  uint64_t heap_solve = 0, heap_full = 0;
  std::vector<TraverseFromSite> solve_poses;
  std::vector<double> solve_times, full_times, window_times, ceres_times[3];
  std::vector<std::vector<double>> per_add(sites - 1);
  CeresRun runs[3];
  WindowRun window_run;
  const bool rover = sites <= kMaxSites;
  const auto window_ground = std::make_unique<GroundSitePoseAdjuster>();  // beyond the rover's kMaxSites
  for (int r = -1; r < repeat; ++r) {  // round -1 warms up (the adjusters' pages first touched), not timed
    const double solve_t = firmwareFull(*ground, solve_only, solve_result, heap_solve);
    solve_poses = posesOf(*ground, false);
    const double full_t = firmwareFull(*ground, defaults, full_result, heap_full);
    for (int d = 0; d < 3; ++d) runs[d] = ceresRun(*ground, defaults, d != 1, d != 2);
    window_run = rover ? firmwareWindow(plan, window, g_rover) : firmwareWindow(plan, window, *window_ground);
    if (r < 0) continue;
    solve_times.push_back(solve_t);
    full_times.push_back(full_t);
    for (int d = 0; d < 3; ++d) ceres_times[d].push_back(runs[d].seconds);
    double total = 0.0;
    for (int32_t k = 0; k < sites - 1; ++k) {
      per_add[k].push_back(window_run.seconds[k]);
      total += window_run.seconds[k];
    }
    window_times.push_back(total / (sites - 1));
  }
  const Timing solve_s = timing(solve_times);
  const Timing full_s = timing(full_times);
  const Timing window_s = timing(window_times);
  double window_worst = 0.0;
  for (const std::vector<double>& t : per_add) window_worst = std::max(window_worst, median(t));
  const double firmware_rms = positionRms(posesOf(*ground, false), plan.truth);
  const Rejections full_rejections = rejectionsOf(*ground, plan, load);
  const char* names[3] = {"Ceres 2.1 DENSE_SCHUR, the firmware's stop rules",
                          "Ceres 2.1 SPARSE_SCHUR, the firmware's stop rules",
                          "Ceres 2.1 DENSE_SCHUR, tight tolerances (1e-14)"};
  const CeresRun& tight = runs[2];
  double rows_rms_px = 0.0;
  const double rows_cost = ground::sitePoseRowsCost(tight.problem, 0.0, &rows_rms_px);

  char problem[200];
  std::snprintf(problem, sizeof problem, "%d sites (%.0f m, %zu points, %zu obs, %d gross, %d unknowns)",
                sites, driven_m, plan.points.size(), plan.observations.size(), gross,
                6 * (sites - 1) + 3 * static_cast<int>(plan.points.size()));
  std::printf("\n%s\n\n", problem);
  std::printf(
      "| problem | solver | seconds, median / best of %d | x firmware solve (median / best) | iterations | "
      "final cost | position RMS vs truth m | note |\n|---|---|---|---|---|---|---|---|\n",
      repeat);
  Row apriori{
      "a priori (odometry chain)", Timing{}, "", -1.0, apriori_rms, "5 % of the leg, 2 deg heading per leg"};
  printRow(problem, apriori, solve_s);
  char note[400];
  std::snprintf(note, sizeof note,
                "%s; %.2f ms per iteration; %d rejected in %d rounds (%d of the %d gross errors, %d good); "
                "sigma0 %.3f; RMS %.3f px; %llu heap allocations in adjust()",
                solve_result.converged ? "converged" : "NOT converged",
                1e3 * solve_s.median / solve_result.iterations_total, solve_result.rejected_observations,
                solve_result.rejection_rounds, full_rejections.caught, gross,
                full_rejections.false_rejections, solve_result.sigma0, solve_result.rms_px,
                static_cast<unsigned long long>(heap_solve));
  Row fw_solve{"firmware, whole traverse (GroundSitePoseAdjuster), solve alone",
               solve_s,
               std::to_string(solve_result.iterations_total) + " (final solve " +
                   std::to_string(solve_result.iterations) + ")",
               solve_result.cost,
               positionRms(solve_poses, plan.truth),
               note};
  printRow(problem, fw_solve, solve_s);
  std::snprintf(
      note, sizeof note,
      "+ the sites' covariance %.5f s (difference of the medians); %llu heap allocations in adjust()",
      full_s.median - solve_s.median, static_cast<unsigned long long>(heap_full));
  Row fw_full{"firmware, whole traverse, default (with covariance)",
              full_s,
              std::to_string(full_result.iterations_total),
              full_result.cost,
              firmware_rms,
              note};
  printRow(problem, fw_full, solve_s);
  std::snprintf(
      note, sizeof note,
      "per added site (%d adds; the slowest add %.5f s, median over the rounds); %.1f iterations per add; %d "
      "rejected (%d of the %d gross errors, %d good); %llu heap allocations over all adds; %s",
      sites - 1, window_worst, static_cast<double>(window_run.iterations) / (sites - 1), window_run.rejected,
      window_run.rejections.caught, gross, window_run.rejections.false_rejections,
      static_cast<unsigned long long>(window_run.heap_allocations),
      rover ? "the rover's SitePoseAdjuster" : "the ground instance (beyond the rover's kMaxSites)");
  Row fw_window{"firmware, sliding window K = " + std::to_string(window) + ", sites added one by one",
                window_s,
                "",
                -1.0,
                window_run.position_rms_m,
                note};
  printRow(problem, fw_window, solve_s);
  for (int d = 0; d < 3; ++d) {
    const CeresRun& c = runs[d];
    const ground::SitePoseDifference a = ground::sitePoseDifference(*ground, c.problem);
    std::snprintf(
        note, sizeof note,
        "%.2f ms per iteration; Huber solve %d steps (%s), final solve %s; max |ceres - firmware| %.3g mm, "
        "%.3g mrad, points %.3g mm",
        1e3 * median(ceres_times[d]) / (c.huber.iterations + c.final.iterations), c.huber.iterations,
        c.huber.termination.c_str(), c.final.termination.c_str(), 1e3 * a.position_m, 1e3 * a.rotation_rad,
        1e3 * a.point_m);
    Row row{names[d],
            timing(ceres_times[d]),
            std::to_string(c.huber.iterations + c.final.iterations) + " (final solve " +
                std::to_string(c.final.iterations) + ")",
            c.final.cost,
            positionRms(c.problem.poses, plan.truth),
            note};
    printRow(problem, row, solve_s);
  }
  std::printf(
      "\nagreement at %d sites: final cost firmware %.6f, Ceres (tight) %.6f (relative %.2e), the firmware's "
      "rows at "
      "Ceres' solution %.6f (RMS %.4f px against the firmware's %.4f px); %d observations and %d points in "
      "Ceres' final solve, %d and %d in the firmware's\n",
      sites, full_result.cost, tight.final.cost, (full_result.cost - tight.final.cost) / tight.final.cost,
      rows_cost, rows_rms_px, full_result.rms_px, tight.final.observations, tight.final.points,
      full_result.active_observations, full_result.solvable_points);
  std::fflush(stdout);
}

std::vector<int32_t> siteList(const std::string& text) {
  std::vector<int32_t> sites;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    char* end = nullptr;
    const long n = std::strtol(item.c_str(), &end, 10);
    if (end == item.c_str() || *end != '\0' || n < 3 || n > kMaxGroundSites)
      throw cli::InputError("--sites", item, "a number of sites in 3.." + std::to_string(kMaxGroundSites));
    sites.push_back(static_cast<int32_t>(n));
  }
  return sites;
}

}  // namespace

int main(int argc, char** argv) {
  return cli::runTool("ground_site_pose_bench", argc, argv, kUsage, [](cli::Args& args) {
    const std::vector<int32_t> sites = siteList(args.option("--sites", "5,10,20"));
    const int repeat = static_cast<int>(args.integer("--repeat", 5));
    const int32_t window = static_cast<int32_t>(args.integer("--window", 4));
    const double outliers = args.number("--outliers", 0.0);
    const uint32_t seed = static_cast<uint32_t>(args.integer("--seed", 1));
    args.finish();
    if (repeat < 1 || window < 1) throw cli::InputError("arguments", "--repeat, --window", "at least 1");
    std::printf(
        "sizeof(SitePoseAdjuster) = %zu bytes (the rover's, static: %d sites), of which PoseSystem %zu "
        "bytes; "
        "sizeof(GroundSitePoseAdjuster) = %zu bytes (%d sites, heap-allocated once); heap counter %s\n",
        sizeof(SitePoseAdjuster), kMaxSites, sizeof(PoseSystem<kMaxSites>), sizeof(GroundSitePoseAdjuster),
        kMaxGroundSites, heapCounterActive() ? "on" : "off");
    for (const int32_t n : sites) benchSites(n, repeat, window, outliers, seed);
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    std::printf("\npeak resident set of the process (Ceres included): %.1f MiB\n", usage.ru_maxrss / 1024.0);
    return 0;
  });
}
