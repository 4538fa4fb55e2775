// areomap-adjust DATASET --out DIR: the constrained bundle adjustment of a dataset from given tie points
// See kUsage.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "firmware_core/adjust/Datum.hpp"
#include "firmware_core/adjust/FastAdjuster.hpp"
#include "firmware_core/adjust/Precision.hpp"
#include "ground/adjust/AdjustProducts.hpp"
#include "ground/adjust/DatasetNetwork.hpp"
#include "ground/adjust/IntegratedAdjuster.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/dataset/TruthFiles.hpp"
#include "ground/io/CameraFile.hpp"

namespace {

const char* kUsage =
    "usage: areomap-adjust DATASET --out DIR (--ties FILE | --truth-ties [--noise-px S] [--seed N])\n"
    "                      [--solver fast|svd|ceres] [--no-gimbal] [--no-base] [--fido] [--no-datum-prior]\n"
    "                      [--sigma-px S] [--no-robust] [--max-sweeps N] [--fast-method M]\n"
    "\n"
    "Constrained bundle adjustment of a panoramic stereo dataset (Di, Xu, Li 3.1-3.5).\n"
    "  DATASET          folder with panorama.json and the a-priori models\n"
    "  --out DIR        writes DIR/models/<stem>.cahvor (adjusted), DIR/eo.csv, DIR/report.json\n"
    "  --ties FILE      tie points, CSV point,image,sample_px,line_px (image = image stem, measured pixels)\n"
    "  --truth-ties     use DATASET/truth/observations.csv plus Gaussian noise of --noise-px S (default "
    "0.3)\n"
    "  --seed N         seed of that noise (default 1)\n"
    "  --solver         fast (default; the rover's adjuster: per-pair 12x12 and per-point 3x3 blocks),\n"
    "                   svd (integrated, dense normal matrix, minimum-norm SVD; small networks only) or\n"
    "                   ceres (integrated, sparse Schur Levenberg-Marquardt)\n"
    "  --no-gimbal      drop the gimbal constraint (Eq. 3)\n"
    "  --no-base        drop the stereo-base constraint (Eq. 4)\n"
    "  --fido           add the FIDO-style constraints (virtual spin centre per tier, distances)\n"
    "  --no-datum-prior drop the weak prior that keeps the a-priori datum\n"
    "  --sigma-px S     a-priori sigma of the image observations (default 0.3)\n"
    "  --no-robust      no outlier rejection\n"
    "  --max-sweeps N   bound of the fast adjuster's sweeps / LM steps (default 1000)\n"
    "  --fast-method M  how the fast adjuster solves: cholesky (default; Levenberg-Marquardt, every point\n"
    "                   eliminated, the reduced camera system of the pairs' 12x12 blocks factorised "
    "jointly),\n"
    "                   pcg (the same LM, the system by block-Jacobi conjugate gradients), gauss-seidel\n"
    "                   (block Gauss-Seidel on the reduced system, pair after pair with its points\n"
    "                   eliminated, Anderson-accelerated; 'alternation' is its former name) or paper (the\n"
    "                   paper's step as written: each pair's EO with the points fixed, then each point with\n"
    "                   the EO fixed, no acceleration; slow to converge, for comparison)\n"
    "Exit codes: 0 ok, 2 usage error, 1 other error.\n";

constexpr int kMaxSvdUnknowns = 5000;  // dense SVD memory and time grow as n^2 and n^3

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

areomap::Network g_net;  // several MiB: static
areomap::FastAdjuster g_fast;

using namespace areomap;

constexpr double kNominalRange_m = 5.0;  // pixel equivalent of EO errors (as in every adjust report)

// The command line, checked.
struct Options {
  std::string out;
  std::optional<std::string> ties;
  bool truth_ties = false;
  double noise_px = 0.3;
  int64_t seed = 1;
  std::string solver;
  ground::RigChoice choice;
  bool robust = true;
  int64_t max_sweeps = 1000;
  FastMethod fast_method = FastMethod::kSchurCholesky;
  std::string dataset_dir;
};

Options parseOptions(cli::Args& args) {
  Options o;
  o.out = args.required("--out");
  o.ties = args.option("--ties");
  o.truth_ties = args.flag("--truth-ties");
  o.noise_px = args.number("--noise-px", 0.3);
  o.seed = args.integer("--seed", 1);
  o.solver = args.option("--solver", "fast");
  o.choice.gimbal = !args.flag("--no-gimbal");
  o.choice.base = !args.flag("--no-base");
  o.choice.fido = args.flag("--fido");
  o.choice.datum_prior = !args.flag("--no-datum-prior");
  o.choice.sigma_px = args.number("--sigma-px", 0.3);
  o.robust = !args.flag("--no-robust");
  o.max_sweeps = args.integer("--max-sweeps", 1000);
  std::string fast_method = args.option("--fast-method", "cholesky");
  o.dataset_dir = args.positional(0, "DATASET");
  if (o.ties.has_value() == o.truth_ties)
    throw cli::UsageError("give exactly one of --ties FILE and --truth-ties");
  if (o.solver != "fast" && o.solver != "svd" && o.solver != "ceres") {
    throw cli::UsageError("--solver: '" + o.solver + "' is not fast, svd or ceres");
  }
  if (!(o.noise_px >= 0.0)) throw cli::UsageError("--noise-px: must be >= 0");
  if (!(o.choice.sigma_px > 0.0)) throw cli::UsageError("--sigma-px: must be > 0");
  if (fast_method == "alternation") fast_method = "gauss-seidel";  // its former name
  if (fast_method == "cholesky") {
    o.fast_method = FastMethod::kSchurCholesky;
  } else if (fast_method == "pcg") {
    o.fast_method = FastMethod::kSchurPcg;
  } else if (fast_method == "gauss-seidel") {
    o.fast_method = FastMethod::kGaussSeidelAnderson;
  } else if (fast_method == "paper") {
    o.fast_method = FastMethod::kPaperAlternation;
  } else {
    throw cli::UsageError("--fast-method: '" + fast_method + "' is not cholesky, pcg, gauss-seidel or paper");
  }
  if (o.max_sweeps < 1 || o.max_sweeps > kMaxFastSweeps) {
    throw cli::UsageError("--max-sweeps: must be 1.." + std::to_string(kMaxFastSweeps));
  }
  return o;
}

// The fast adjustment (and, for svd / ceres, its outlier rejection): the report's solver figures.
FastAdjustResult fastAdjustment(const Options& o, const Dataset& dataset, const ground::NetworkSource& source,
                                ground::AdjustReport& report) {
  FastAdjustOptions options;
  options.max_sweeps = static_cast<int32_t>(o.max_sweeps);
  options.robust = o.robust;
  options.method = o.fast_method;
  FastAdjustResult fr;
  const Status s = g_fast.adjust(g_net, options, fr);
  if (!ok(s)) {
    std::string what = std::string("the adjustment failed: ") + statusName(s);
    if (fr.degenerate_image >= 0) {
      what += " (image '" + source.stems[fr.degenerate_image] +
              "' has fewer than 3 usable tie points or all on one line)";
    }
    throw cli::InputError(o.ties ? *o.ties : dataset.root + "/" + kTruthObservationsFile, "point", what);
  }
  report.solver =
      o.solver == "fast" ? std::string("fast (") + fastMethodName(options.method) + ")" : o.solver;
  report.stop_rule = stopRuleName(fr.stop_rule);
  report.iterations = fr.sweeps;
  report.sigma0 = fr.sigma0;
  report.rms_px = fr.rms_px;
  if (o.solver == "fast" && !ok(fr.covariance_status))
    report.warnings.push_back(ground::covarianceWarning(fr.covariance_status));
  if (fr.stop_rule == StopRule::kMaxSweeps) {
    report.warnings.push_back("The fast adjustment reached its sweep bound (" + std::to_string(o.max_sweeps) +
                              ") before its stop rule held.");
  }
  return fr;
}

// The integrated adjustment (svd / ceres) from the a-priori EO with the fast adjuster's rejections.
void integratedAdjustment(const std::string& solver, ground::AdjustReport& report) {
  std::vector<bool> rejected(g_net.observationCount());
  for (int k = 0; k < g_net.observationCount(); ++k) rejected[k] = g_net.observation(k).rejected;
  g_net.resetToApriori();
  for (int k = 0; k < g_net.observationCount(); ++k) g_net.observation(k).rejected = rejected[k];
  int32_t failed = 0;
  (void)g_net.triangulateAll(failed);
  ground::IntegratedResult ir;
  if (solver == "svd") {
    int unknowns = 6 * g_net.imageCount();
    for (int p = 0; p < g_net.pointCount(); ++p) unknowns += g_net.point(p).solvable ? 3 : 0;
    if (unknowns > kMaxSvdUnknowns) {
      throw cli::UsageError("--solver svd: " + std::to_string(unknowns) +
                            " unknowns exceed the dense limit " + std::to_string(kMaxSvdUnknowns) +
                            "; use ceres or fast");
    }
    ir = ground::adjustSvd(g_net);
  } else {
    ir = ground::adjustCeres(g_net);
  }
  if (!ir.converged) report.warnings.push_back("The " + solver + " adjustment did not report convergence.");
  if (!ir.covariance_note.empty()) report.warnings.push_back(ir.covariance_note);
  report.iterations = ir.iterations;
  report.rms_px = ir.rms_px;
  report.sigma0 = ir.sigma0;
  report.stop_rule = ir.converged ? "converged" : "not_converged";
}

// The truth figures of the solution (EO always, points with --truth-ties).
ground::TruthFigures truthFigures(const ground::NetworkTruth& truth, std::optional<double> eo_before,
                                  ground::AdjustReport& report) {
  const Vec3* tp = truth.points.empty() ? nullptr : truth.points.data();
  const Vec3 gimbal = g_net.rig.gimbal_m[0];
  const TruthErrors aligned =
      truthErrors(g_net, truth.centres.data(), truth.rotations.data(), tp, gimbal, true, kNominalRange_m);
  const TruthErrors raw =
      truthErrors(g_net, truth.centres.data(), truth.rotations.data(), tp, gimbal, false, kNominalRange_m);
  ground::TruthFigures t;
  t.eo_px = aligned.eo_px;
  t.eo_px_raw = raw.eo_px;
  t.eo_px_before = eo_before;
  if (tp != nullptr && aligned.points > 0) {
    t.ground_m = aligned.ground_m;
    t.ground_m_raw = raw.ground_m;
  } else {
    report.warnings.push_back(
        "truth.ground_m is not given: tie points have true positions only with --truth-ties.");
  }
  report.warnings.push_back("truth.dem_rmse_m is not given: areomap-adjust makes no DEM.");
  return t;
}

}  // namespace

int main(int argc, char** argv) {
  return cli::runTool("areomap-adjust", argc, argv, kUsage, [](cli::Args& args) {
    const Options o = parseOptions(args);
    ground::AdjustReport report;
    auto t0 = Clock::now();
    const Dataset dataset = readDataset(o.dataset_dir);
    for (const std::string& note : dataset.notes) report.warnings.push_back(note);
    const std::vector<ImageObservation> observations =
        o.truth_ties ? ground::noisyTruthObservations(dataset, o.noise_px, static_cast<uint64_t>(o.seed))
                     : readTiePointsCsv(*o.ties);
    ground::NetworkSource source;
    ground::buildNetwork(dataset, observations, o.choice, g_net, source);
    for (const std::string& w : source.warnings) report.warnings.push_back(w);
    report.estimated = source.estimated;
    report.constraints = {{"gimbal", o.choice.gimbal},
                          {"base", o.choice.base},
                          {"fido", o.choice.fido},
                          {"datum_prior", o.choice.datum_prior}};
    cli::info("network: " + std::to_string(g_net.pairCount()) + " pairs, " +
              std::to_string(g_net.imageCount()) + " images, " + std::to_string(g_net.pointCount()) +
              " points, " + std::to_string(g_net.observationCount()) + " observations");
    report.seconds.emplace_back("load", since(t0));

    t0 = Clock::now();
    report.method1_before = precisionMethod1(g_net);
    report.method2_before = precisionMethod2(g_net);
    report.method3_before = precisionMethod3(g_net);
    // Truth: true models (and true points for --truth-ties).
    const ground::NetworkTruth truth = ground::loadNetworkTruth(dataset, source, o.truth_ties);
    std::optional<double> eo_before;
    if (truth.available) {
      eo_before = truthErrors(g_net, truth.centres.data(), truth.rotations.data(), nullptr,
                              g_net.rig.gimbal_m[0], true, kNominalRange_m)
                      .eo_px;
    }
    report.seconds.emplace_back("precision_before", since(t0));

    t0 = Clock::now();
    const FastAdjustResult fr = fastAdjustment(o, dataset, source, report);
    report.seconds.emplace_back(o.solver == "fast" ? "adjust" : "rejection", since(t0));
    if (o.solver != "fast") {
      t0 = Clock::now();
      integratedAdjustment(o.solver, report);
      report.seconds.emplace_back("adjust", since(t0));
    }

    t0 = Clock::now();
    report.method1_after = precisionMethod1(g_net);
    report.method2_after = precisionMethod2(g_net);
    report.method3_after = precisionMethod3(g_net);
    report.tie_points = countTiePoints(g_net);
    ground::setRigFigures(report, g_net);  // of the solution written (the integrated one for svd / ceres)
    if (truth.available) report.truth = truthFigures(truth, eo_before, report);
    report.seconds.emplace_back("precision_after", since(t0));

    t0 = Clock::now();
    ground::writeAdjustedModels(o.out + "/models", g_net, source.apriori_models, source.stems);
    ground::writeEoCsv(o.out + "/eo.csv", g_net, source.stems);
    report.seconds.emplace_back("write", since(t0));
    ground::writeReportJson(o.out + "/report.json", report);
    cli::info("adjusted (" + o.solver + "): rms " + std::to_string(report.rms_px) + " px, sigma0 " +
              std::to_string(report.sigma0) + ", " + std::to_string(report.iterations) + " iterations, " +
              std::to_string(fr.rejected_observations) + " observations rejected; products in " + o.out);
    return 0;
  });
}
