// areomap-adjust-bench: fast vs integrated-SVD vs Ceres sparse Schur, side by side in one process, on
// simulated datasets (areomap-sim output, truth observations + 0.3 px noise, no outliers, no rejection),
// and the BAL problem through the generic parts (every fast method vs Ceres, intrinsics held fixed). Each
// fast method is timed on its solve alone; the EO covariance that adjust() adds is timed on its own.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "firmware_core/adjust/Datum.hpp"
#include "firmware_core/adjust/FastAdjuster.hpp"
#include "ground/adjust/DatasetNetwork.hpp"
#include "ground/adjust/IntegratedAdjuster.hpp"
#include "ground/cli/Cli.hpp"

namespace {

using namespace areomap;
using Clock = std::chrono::steady_clock;

const char* kUsage =
    "usage: areomap-adjust-bench [DATASET...] [--bal FILE] [--svd-max-unknowns N] [--repeat N] [--pcg-tol "
    "T]\n"
    "Prints a markdown table: wall time, iterations, final method-1 RMS, EO and ground error vs truth.\n";

double g_pcg_tolerance = 1e-3;
Network g_start;
Network g_work;
FastAdjuster g_fast;

double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

struct Row {
  std::string name;
  double seconds = 0.0;
  int iterations = 0;
  double rms_px = 0.0;
  double cost = 0.0;
  double eo_px = -1.0;
  double ground_m = -1.0;
  std::string note;
};

void printRow(const std::string& problem, const Row& r, double fast_seconds) {
  std::printf("| %s | %s | %.4f | %.0fx | %d | %.4f | %.3f | %s | %s | %s |\n", problem.c_str(),
              r.name.c_str(), r.seconds, r.seconds / fast_seconds, r.iterations, r.rms_px, r.cost,
              r.eo_px >= 0 ? std::to_string(r.eo_px).c_str() : "-",
              r.ground_m >= 0 ? std::to_string(r.ground_m).c_str() : "-", r.note.c_str());
}

void truthFigures(const ground::NetworkTruth& t, Row& r) {
  if (!t.available) return;
  const TruthErrors e =
      truthErrors(g_work, t.centres.data(), t.rotations.data(), t.points.empty() ? nullptr : t.points.data(),
                  g_work.rig.gimbal_m[0], true, 5.0);
  r.eo_px = e.eo_px;
  r.ground_m = e.ground_m;
}

int unknownsOf(const Network& net) {
  int u = 6 * net.imageCount();
  for (int p = 0; p < net.pointCount(); ++p) u += net.point(p).solvable ? 3 : 0;
  return u;
}

void benchNetwork(const std::string& problem, const ground::NetworkTruth& truth, int svd_max, int repeat,
                  const FastAdjustOptions& fast_options) {
  Row fast, alternation, paper, pcg, ceres, svd;
  fast.name = "fast (default: LM, RCS by block Cholesky)";
  alternation.name = "fast (block Gauss-Seidel on the RCS + Anderson)";
  paper.name = "fast (the paper's alternation as written: pairs with points fixed, then points)";
  pcg.name = "fast (LM, RCS by PCG, 12x12 block-Jacobi)";
  ceres.name = "ceres sparse Schur";
  svd.name = "integrated SVD";
  const auto runFast = [&](FastMethod method, Row& row) {
    row.seconds = 1e30;
    FastAdjustOptions o = fast_options;
    o.method = method;
    o.eo_covariance = false;  // the solve alone; the covariance is timed on its own below
    o.pcg_relative_tolerance = g_pcg_tolerance;
    for (int k = 0; k < repeat; ++k) {
      g_work = g_start;
      FastAdjustResult fr;
      const auto t0 = Clock::now();
      const Status s = g_fast.adjust(g_work, o, fr);
      row.seconds = std::min(row.seconds, since(t0));
      row.iterations = fr.sweeps;
      row.rms_px = fr.rms_px;
      row.cost = fr.cost;
      row.note = std::string(statusName(s)) + ", stop " + stopRuleName(fr.stop_rule);
      if (method == FastMethod::kPaperAlternation) {
        row.note += ", largest EO step of the last sweep " + std::to_string(fr.last_step_px) + " px";
      } else if (method == FastMethod::kGaussSeidelAnderson) {
        row.note += ", Anderson " + std::to_string(fr.anderson_accepted) + "/" +
                    std::to_string(fr.anderson_accepted + fr.anderson_rejected);
      } else if (method == FastMethod::kSchurPcg || fr.cholesky_fallback) {
        row.note += ", " + std::to_string(fr.pcg_iterations) + " CG steps" +
                    (fr.cholesky_fallback ? " (factor beyond the pool: PCG fallback)" : "");
      } else {
        row.note += ", " + std::to_string(fr.factorisations) + " factorisations of " +
                    std::to_string(fr.factor_blocks) + " 12x12 blocks";
      }
    }
    truthFigures(truth, row);
  };
  runFast(FastMethod::kSchurPcg, pcg);
  runFast(FastMethod::kGaussSeidelAnderson, alternation);
  runFast(FastMethod::kPaperAlternation, paper);
  runFast(FastMethod::kSchurCholesky, fast);  // last: its solution is compared with Ceres' below
  // The EO covariance at the default's solution (EoCovariance.hpp), which adjust() adds by default.
  double covariance_seconds = 1e30;
  for (int k = 0; k < repeat; ++k) {
    FastAdjustResult pr;
    const auto t0 = Clock::now();
    (void)g_fast.precisionOf(g_work, pr);
    covariance_seconds = std::min(covariance_seconds, since(t0));
  }
  fast.note += "; + EO covariance " + std::to_string(covariance_seconds) + " s";

  Network* fast_solution = new Network(g_work);
  ceres.seconds = 1e30;
  for (int k = 0; k < repeat; ++k) {
    g_work = g_start;
    const ground::IntegratedResult r = ground::adjustCeres(g_work);
    ceres.seconds = std::min(ceres.seconds, r.seconds);
    ceres.iterations = r.iterations;
    ceres.rms_px = r.rms_px;
    ceres.cost = r.cost;
    ceres.note = r.converged ? "converged" : "NOT converged";
  }
  truthFigures(truth, ceres);
  double d_eo = 0.0, d_ground = 0.0;
  for (int i = 0; i < g_work.imageCount(); ++i) {
    d_eo =
        std::max(d_eo, eoPixelEquivalent(g_work.image(i).io.f_px,
                                         g_work.image(i).centre_m - fast_solution->image(i).centre_m,
                                         rotationAngle(g_work.image(i).m, fast_solution->image(i).m), 5.0));
  }
  for (int p = 0; p < g_work.pointCount(); ++p) {
    if (g_work.point(p).solvable && fast_solution->point(p).solvable) {
      d_ground = std::max(d_ground, (g_work.point(p).xyz_m - fast_solution->point(p).xyz_m).norm());
    }
  }
  char buf[160];
  std::snprintf(buf, sizeof buf, "; ceres / fast time %.2f; max |fast - ceres|: EO %.5f px, ground %.6f m",
                ceres.seconds / fast.seconds, d_eo, d_ground);
  ceres.note += buf;
  delete fast_solution;
  const int u = unknownsOf(g_start);
  std::printf("\n%s: %d images, %d points, %d observations, %d unknowns\n\n", problem.c_str(),
              g_start.imageCount(), g_start.pointCount(), g_start.observationCount(), u);
  std::printf(
      "| problem | solver | seconds | x fast | iterations | RMS px (method 1) | cost | EO err px (aligned) "
      "| ground err m (aligned) | note |\n|---|---|---|---|---|---|---|---|---|---|\n");
  printRow(problem, fast, fast.seconds);
  printRow(problem, pcg, fast.seconds);
  printRow(problem, alternation, fast.seconds);
  printRow(problem, paper, fast.seconds);
  printRow(problem, ceres, fast.seconds);
  if (u <= svd_max) {
    g_work = g_start;
    const ground::IntegratedResult r = ground::adjustSvd(g_work);
    svd.seconds = r.seconds;
    svd.iterations = r.iterations;
    svd.rms_px = r.rms_px;
    svd.cost = r.cost;
    svd.note = r.converged ? "converged" : "NOT converged";
    char ratio[160];
    std::snprintf(ratio, sizeof ratio, "; svd / paper alternation time %.1f, svd / default %.1f",
                  svd.seconds / paper.seconds, svd.seconds / fast.seconds);
    svd.note += ratio;
    truthFigures(truth, svd);
    printRow(problem, svd, fast.seconds);
  } else {
    std::printf("| %s | integrated SVD | - | - | - | - | - | - | - | skipped: %d unknowns > %d |\n",
                problem.c_str(), u, svd_max);
  }
  std::fflush(stdout);
}

void benchDataset(const std::string& dir, int svd_max, int repeat) {
  const Dataset dataset = readDataset(dir);
  const std::vector<ImageObservation> obs = ground::noisyTruthObservations(dataset, 0.3, 1);
  ground::NetworkSource source;
  ground::buildNetwork(dataset, obs, ground::RigChoice{}, g_start, source);
  const ground::NetworkTruth truth = ground::loadNetworkTruth(dataset, source, true);
  // The simulator's true observations hold a few gross errors (points seen through the distortion
  // fold-over outside the field): one robust fast run marks them, then every solver starts from the a-priori
  // EO with the same rejection flags and no further rejection.
  g_work = g_start;
  FastAdjustResult pre;
  FastAdjustOptions robust_options;
  (void)g_fast.adjust(g_work, robust_options, pre);
  int rejected = 0;
  for (int k = 0; k < g_start.observationCount(); ++k) {
    g_start.observation(k).rejected = g_work.observation(k).rejected;
    rejected += g_start.observation(k).rejected ? 1 : 0;
  }
  int32_t failed = 0;
  (void)g_start.triangulateAll(failed);
  std::printf(
      "\n%s: %d observations rejected before the comparison (at triangulation and by the robust pre-run)\n",
      dir.c_str(), rejected);
  FastAdjustOptions options;
  options.robust = false;  // all solvers see the same observations
  benchNetwork(dataset.name.empty() ? dir : dataset.name, truth, svd_max, repeat, options);
}

// BAL: cameras [angle-axis R, t, f, k1, k2], P = R X + t, p = -P / P.z, pixel = f r(p) p (y up, origin at the
// centre). Intrinsics are held fixed: each observation is undistorted once to an ideal pixel.
void benchBal(const std::string& path, int repeat) {
  std::ifstream in(path);
  if (!in) throw cli::InputError(path, "file", "cannot be read");
  int n_cam = 0, n_pt = 0, n_obs = 0;
  in >> n_cam >> n_pt >> n_obs;
  if (!in || n_cam <= 0 || n_cam > kMaxPairs || n_pt <= 0 || n_pt > kMaxTiePoints ||
      n_obs > kMaxObservations) {
    throw cli::InputError(path, "header", "counts outside the network capacities");
  }
  std::vector<int> oc(n_obs), op(n_obs);
  std::vector<double> ox(n_obs), oy(n_obs);
  for (int k = 0; k < n_obs; ++k) in >> oc[k] >> op[k] >> ox[k] >> oy[k];
  std::vector<double> cam(9 * static_cast<size_t>(n_cam)), pts(3 * static_cast<size_t>(n_pt));
  for (double& v : cam) in >> v;
  for (double& v : pts) in >> v;
  if (!in) throw cli::InputError(path, "body", "truncated");
  g_start.clear();
  g_start.rig = RigConstraints{};
  g_start.rig.use_gimbal = false;
  g_start.rig.use_base = false;
  g_start.rig.use_datum_prior = false;
  for (int c = 0; c < n_cam; ++c) {
    const double* x = &cam[9 * c];
    const Mat3 r = rotationFromVector(Vec3(x[0], x[1], x[2]));
    InteriorOrientation io;
    io.f_px = x[6];
    const Vec3 centre = -(r.transpose() * Vec3(x[3], x[4], x[5]));
    int32_t pair = 0;
    if (!ok(g_start.addPair(0, 0, io, centre, r, nullptr, centre, r, pair)))
      throw cli::InputError(path, "camera", "bad");
  }
  for (int p = 0; p < n_pt; ++p) {
    int32_t idx = 0;
    if (!ok(g_start.addPoint(Vec3(pts[3 * p], pts[3 * p + 1], pts[3 * p + 2]), idx))) {
      throw cli::InputError(path, "point", "bad");
    }
  }
  int dropped = 0;
  for (int k = 0; k < n_obs; ++k) {
    const double* x = &cam[9 * oc[k]];
    const double f = x[6], k1 = x[7], k2 = x[8];
    // Undistort: find p with f r(p) p = observed (fixed point on the radius).
    const Vec2 d(ox[k] / f, oy[k] / f);
    Vec2 u = d;
    for (int it = 0; it < 50; ++it) {
      const double r2 = u.squaredNorm();
      u = d / (1.0 + k1 * r2 + k2 * r2 * r2);
    }
    // BAL y is up with p = -P/P.z; the network's line = -f p_y (collinearity(): line = y0 + f d_y / d_z).
    const Vec2 ideal(f * u.x(), -f * u.y());
    if (!ok(g_start.addObservation(op[k], oc[k], ideal, 1.0))) ++dropped;
  }
  // Observations whose point is behind the camera at the start cannot be used by either solver.
  int behind = 0;
  for (int k = 0; k < g_start.observationCount(); ++k) {
    NetObservation& o = g_start.observation(k);
    Vec2 q;
    const NetImage& im = g_start.image(o.image);
    if (!ok(collinearity(im.io, im.centre_m, im.m, g_start.point(o.point).xyz_m, q))) {
      o.rejected = true;
      ++behind;
    }
  }
  std::printf(
      "\nBAL %s: %d cameras (intrinsics fixed), %d points, %d observations (%d over the %d-per-point "
      "capacity dropped, %d behind their camera at the start left out), sigma 1 px, no constraints, "
      "no datum prior\n",
      path.c_str(), n_cam, n_pt, n_obs, dropped, kMaxObsPerPoint, behind);
  FastAdjustOptions options;
  options.robust = false;
  options.max_sweeps = kMaxFastSweeps;
  options.nominal_range_m = 5.0;
  benchNetwork("bal-ladybug-49", ground::NetworkTruth{}, 0, repeat, options);
}

}  // namespace

int main(int argc, char** argv) {
  return cli::runTool("areomap-adjust-bench", argc, argv, kUsage, [](cli::Args& args) {
    const std::optional<std::string> bal = args.option("--bal");
    const int svd_max = static_cast<int>(args.integer("--svd-max-unknowns", 4000));
    const int repeat = static_cast<int>(args.integer("--repeat", 3));
    g_pcg_tolerance = args.number("--pcg-tol", g_pcg_tolerance);
    std::vector<std::string> datasets;
    for (std::size_t i = 0; i < args.positionalCount(); ++i)
      datasets.push_back(args.positional(i, "DATASET"));
    for (const std::string& d : datasets) benchDataset(d, svd_max, repeat);
    if (bal) benchBal(*bal, repeat);
    return 0;
  });
}
