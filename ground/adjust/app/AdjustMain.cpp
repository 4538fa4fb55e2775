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

}  // namespace

int main(int argc, char** argv) {
  using namespace areomap;
  return cli::runTool("areomap-adjust", argc, argv, kUsage, [](cli::Args& args) {
    const std::string out = args.required("--out");
    const std::optional<std::string> ties = args.option("--ties");
    const bool truth_ties = args.flag("--truth-ties");
    const double noise_px = args.number("--noise-px", 0.3);
    const int64_t seed = args.integer("--seed", 1);
    const std::string solver = args.option("--solver", "fast");
    ground::RigChoice choice;
    choice.gimbal = !args.flag("--no-gimbal");
    choice.base = !args.flag("--no-base");
    choice.fido = args.flag("--fido");
    choice.datum_prior = !args.flag("--no-datum-prior");
    choice.sigma_px = args.number("--sigma-px", 0.3);
    const bool robust = !args.flag("--no-robust");
    const int64_t max_sweeps = args.integer("--max-sweeps", 1000);
    std::string fast_method = args.option("--fast-method", "cholesky");
    const std::string dataset_dir = args.positional(0, "DATASET");
    if (ties.has_value() == truth_ties)
      throw cli::UsageError("give exactly one of --ties FILE and --truth-ties");
    if (solver != "fast" && solver != "svd" && solver != "ceres") {
      throw cli::UsageError("--solver: '" + solver + "' is not fast, svd or ceres");
    }
    if (!(noise_px >= 0.0)) throw cli::UsageError("--noise-px: must be >= 0");
    if (!(choice.sigma_px > 0.0)) throw cli::UsageError("--sigma-px: must be > 0");
    if (fast_method == "alternation") fast_method = "gauss-seidel";
    if (fast_method != "cholesky" && fast_method != "pcg" && fast_method != "gauss-seidel" &&
        fast_method != "paper") {
      throw cli::UsageError("--fast-method: '" + fast_method +
                            "' is not cholesky, pcg, gauss-seidel or paper");
    }
    if (max_sweeps < 1 || max_sweeps > kMaxFastSweeps) {
      throw cli::UsageError("--max-sweeps: must be 1.." + std::to_string(kMaxFastSweeps));
    }

    ground::AdjustReport report;
    auto t0 = Clock::now();
    const Dataset dataset = readDataset(dataset_dir);
    for (const std::string& note : dataset.notes) report.warnings.push_back(note);
    const std::vector<ImageObservation> observations =
        truth_ties ? ground::noisyTruthObservations(dataset, noise_px, static_cast<uint64_t>(seed))
                   : readTiePointsCsv(*ties);
    ground::NetworkSource source;
    ground::buildNetwork(dataset, observations, choice, g_net, source);
    for (const std::string& w : source.warnings) report.warnings.push_back(w);
    report.estimated = source.estimated;
    report.constraints = {{"gimbal", choice.gimbal},
                          {"base", choice.base},
                          {"fido", choice.fido},
                          {"datum_prior", choice.datum_prior}};
    cli::info("network: " + std::to_string(g_net.pairCount()) + " pairs, " +
              std::to_string(g_net.imageCount()) + " images, " + std::to_string(g_net.pointCount()) +
              " points, " + std::to_string(g_net.observationCount()) + " observations");
    report.seconds.emplace_back("load", since(t0));

    t0 = Clock::now();
    report.method1_before = precisionMethod1(g_net);
    report.method2_before = precisionMethod2(g_net);
    report.method3_before = precisionMethod3(g_net);

    // Truth: true models (and true points for --truth-ties).
    const ground::NetworkTruth truth = ground::loadNetworkTruth(dataset, source, truth_ties);
    const bool have_truth = truth.available;
    const std::vector<Vec3>& true_centers = truth.centers;
    const std::vector<Mat3>& true_rotations = truth.rotations;
    const std::vector<Vec3>& true_points = truth.points;
    std::optional<double> eo_before;
    if (have_truth) {
      eo_before = truthErrors(g_net, true_centers.data(), true_rotations.data(), nullptr,
                              g_net.rig.gimbal_m[0], true, 5.0)
                      .eo_px;
    }
    report.seconds.emplace_back("precision_before", since(t0));

    t0 = Clock::now();
    FastAdjustOptions options;
    options.max_sweeps = static_cast<int32_t>(max_sweeps);
    options.robust = robust;
    options.method = fast_method == "pcg"            ? FastMethod::kSchurPcg
                     : fast_method == "gauss-seidel" ? FastMethod::kGaussSeidelAnderson
                     : fast_method == "paper"        ? FastMethod::kPaperAlternation
                                                     : FastMethod::kSchurCholesky;
    FastAdjustResult fr;
    const Status s = g_fast.adjust(g_net, options, fr);
    if (!ok(s)) {
      std::string what = std::string("the adjustment failed: ") + statusName(s);
      if (fr.degenerate_image >= 0) {
        what += " (image '" + source.stems[fr.degenerate_image] +
                "' has fewer than 3 usable tie points or all on one line)";
      }
      throw cli::InputError(ties ? *ties : dataset.root + "/" + kTruthObservationsFile, "point", what);
    }
    report.seconds.emplace_back(solver == "fast" ? "adjust" : "rejection", since(t0));
    report.solver = solver == "fast" ? std::string("fast (") + fastMethodName(options.method) + ")" : solver;
    report.stop_rule = stopRuleName(fr.stop_rule);
    report.iterations = fr.sweeps;
    report.sigma0 = fr.sigma0;
    report.rms_px = fr.rms_px;
    if (solver == "fast" && !ok(fr.covariance_status)) {
      report.warnings.push_back(std::string("eo.csv sigmas are zero: the reduced camera system is ") +
                                statusName(fr.covariance_status) +
                                " (the constraints do not make the network rigid).");
    }
    if (fr.stop_rule == StopRule::kMaxSweeps) {
      report.warnings.push_back("The fast adjustment reached its sweep bound (" + std::to_string(max_sweeps) +
                                ") before its stop rule held.");
    }
    if (solver != "fast") {
      t0 = Clock::now();
      // The integrated adjusters start again from the a-priori EO, with the fast adjuster's rejections.
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
      if (!ir.converged)
        report.warnings.push_back("The " + solver + " adjustment did not report convergence.");
      if (!ir.covariance_note.empty())
        report.warnings.push_back("eo.csv sigmas are zero: " + ir.covariance_note + ".");
      report.iterations = ir.iterations;
      report.rms_px = ir.rms_px;
      report.sigma0 = ir.sigma0;
      report.stop_rule = ir.converged ? "converged" : "not_converged";
      report.seconds.emplace_back("adjust", since(t0));
    }
    t0 = Clock::now();
    report.method1_after = precisionMethod1(g_net);
    report.method2_after = precisionMethod2(g_net);
    report.method3_after = precisionMethod3(g_net);
    report.tie_points = countTiePoints(g_net);
    ground::setRigFigures(report, g_net);  // of the solution written (the integrated one for svd / ceres)
    if (have_truth) {
      const Vec3* tp = true_points.empty() ? nullptr : true_points.data();
      const TruthErrors aligned = truthErrors(g_net, true_centers.data(), true_rotations.data(), tp,
                                              g_net.rig.gimbal_m[0], true, 5.0);
      const TruthErrors raw = truthErrors(g_net, true_centers.data(), true_rotations.data(), tp,
                                          g_net.rig.gimbal_m[0], false, 5.0);
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
      report.truth = t;
    }
    report.seconds.emplace_back("precision_after", since(t0));
    t0 = Clock::now();
    ground::writeAdjustedModels(out + "/models", g_net, source.apriori_models, source.stems);
    ground::writeEoCsv(out + "/eo.csv", g_net, source.stems);
    report.seconds.emplace_back("write", since(t0));
    ground::writeReportJson(out + "/report.json", report);
    cli::info("adjusted (" + solver + "): rms " + std::to_string(report.rms_px) + " px, sigma0 " +
              std::to_string(report.sigma0) + ", " + std::to_string(report.iterations) + " iterations, " +
              std::to_string(fr.rejected_observations) + " observations rejected; products in " + out);
    return 0;
  });
}
