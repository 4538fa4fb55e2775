// areomap-traverse DATASET --out DIR: one map and the rover's positions over a multi-site traverse. See
// kUsage.
#include <algorithm>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "ground/cli/Cli.hpp"
#include "ground/cli/Process.hpp"
#include "ground/dataset/Traverse.hpp"
#include "ground/traverse/SiteJobs.hpp"
#include "ground/traverse/SlurmJobs.hpp"
#include "ground/traverse/TraverseRun.hpp"

namespace areomap {
namespace {

constexpr const char* kUsage =
    "usage: areomap-traverse DATASET --out DIR [--cross-ties FILE | --truth-cross-ties [--noise-px S] |\n"
    "                        --no-cross-ties] [--no-products] [--reuse-sites | --resume] [--cell-m C] [--quiet]\n"
    "                        [--threads N]\n"
    "                        [--jobs N | --executor slurm [--partition P] [--sbatch-arg ARG]... [--no-wait]]\n"
    "       areomap-traverse DATASET --out DIR --site K [--no-products] [--quiet]\n"
    "       areomap-traverse DATASET --out DIR --join [the cross-site options above]\n"
    "\n"
    "Maps a multi-site traverse: DATASET/traverse.json names the sites in driving order "
    "(docs/traverse.md),\n"
    "each a single-site dataset in its own site frame. Every site is mapped alone by the "
    "ground\n"
    "pass (as areomap-ground --dataset) into DIR/sites/<id>/; cross-site tie points are matched between\n"
    "neighbouring sites (as areomap-cross-ties: DEM registration, NCC on DEM-warped patches; "
    "DIR/cross_ties.csv\n"
    "and cross_ties.json; across a traversing stop, \"kind\": \"stop\", also back to the last panorama\n"
    "site); the sites are placed in the traverse frame (the first site's) by the multi-site adjustment of\n"
    "those ties and the odometry (firmware_core/adjust/SitePoseAdjuster.hpp); and DIR gets poses.csv (site,\n"
    "x, y, z, heading, their sigmas, the pose's source, distance\n"
    "driven), the merged dem.tif, dem_sigma.tif and ortho.tif (traverse frame; each cell from the nearest "
    "site\n"
    "that has data there) and report.json (traverse.sites, stops, distance_m, position_error_m / _pct and\n"
    "position_error_apriori_pct against DATASET/truth/traverse.json when it exists, cross_site_ties, "
    "per-site\n"
    "figures; method1_px / method2_m / method3_px as the mean of the sites').\n"
    "\n"
    "  --out DIR        output folder (created)\n"
    "  --no-products    adjustment only: no dense matching, DEM, ortho, merged map or cross-site matching\n"
    "  --cell-m C       merged map cell (default: the coarsest site dem.tif cell)\n"
    "  --cross-ties FILE  cross-site tie points from a file instead of the matcher, CSV\n"
    "                   point,site,image,sample_px,line_px (measured pixels; e.g. areomap-cross-ties')\n"
    "  --no-cross-ties  no cross-site ties: the poses are the odometry's (chained, with its sigmas)\n"
    "  --truth-cross-ties  cross-site ties from a synthetic traverse's truth (each site's check points\n"
    "                   projected into the previous site's true models) with --noise-px S (default 0.3)\n"
    "  --reuse-sites    a site whose DIR/sites/<id> holds a finished pass (report.json, models/) is not\n"
    "                   mapped again (e.g. to adjust the traverse again with other cross-site ties)\n"
    "  --resume         a site whose DIR/sites/<id>/manifest.json says it was mapped, every file matching\n"
    "                   its size and SHA-256, is not mapped again; every other site is (killed, failed,\n"
    "                   half written)\n"
    "  --quiet          no progress lines\n"
    "  --threads N      threads of the passes' parallel work (pairs, rows, cells; default: every core);\n"
    "                   the products are the same bytes for any N\n"
    "\n"
    "Sites as jobs (docs/traverse.md \"Sites as jobs\"): each site's pass is the command\n"
    "  areomap-traverse DATASET --out DIR --site K    (K: 1-based index or site id)\n"
    "which maps that site alone into DIR/sites/<id>/ and ends with its manifest.json; when every site's\n"
    "job has ended well, \"--join\" runs the cross-site step on what they wrote.\n"
    "  --jobs N         N site passes at a time as child processes, logs in DIR/logs/ (default: the\n"
    "                   machine's cores; 1: one after the other in this process)\n"
    "  --executor slurm  the sites' passes as one Slurm job array (sbatch --array), the cross-site step as a\n"
    "                   job after it (afterok; cancelled when a task fails); waits, showing progress.\n"
    "                   DIR and DATASET must be on storage every node shares\n"
    "  --partition P    Slurm partition (default: the cluster's)\n"
    "  --sbatch-arg ARG  passed to sbatch for every job (repeatable), e.g. --sbatch-arg=--mem=2G\n"
    "  --no-wait        print the job ids and the command that finishes the run, and exit\n"
    "\n"
    "A site whose pass fails for its data (a bad dataset, an unsolvable network) is reported in report.json\n"
    "and skipped; the others are still mapped. A site's job that fails (killed, its folder not writable)\n"
    "stops the cross-site step: report.json (\"status\": \"incomplete\") says which site and why; --resume\n"
    "goes on. Exit: 0 ok, 2 usage error, 1 other error (the message names the file and field), also 1 when\n"
    "a product could not be written or a site's job failed.\n";


// The options of the pass and of the cross-site step.
traverse::TraverseRunOptions runOptions(cli::Args& args) {
  traverse::TraverseRunOptions o;
  o.out_dir = args.required("--out");
  o.products = !args.flag("--no-products");
  o.cell_m = args.number("--cell-m", -1.0);
  o.progress = !args.flag("--quiet");
  cli::threadsOption(args);
  o.reuse_sites = args.flag("--reuse-sites");
  o.resume = args.flag("--resume");
  o.cross_ties_csv = args.option("--cross-ties", "");
  o.truth_cross_ties = args.flag("--truth-cross-ties");
  o.truth_noise_px = args.number("--noise-px", 0.3);
  o.match_cross_ties = !args.flag("--no-cross-ties");
  if (int(o.truth_cross_ties) + int(!o.cross_ties_csv.empty()) + int(!o.match_cross_ties) > 1)
    throw cli::UsageError("give at most one of --cross-ties FILE, --truth-cross-ties and --no-cross-ties");
  if (o.reuse_sites && o.resume) throw cli::UsageError("give --reuse-sites or --resume, not both");
  return o;
}

// How the sites' passes run.
struct Execution {
  std::string site;  // --site K
  bool join = false;
  std::string executor = "local";
  int jobs = 1;
  traverse::SlurmOptions slurm;
  bool wait = true;
};

Execution execution(cli::Args& args) {
  Execution e;
  // First: an sbatch argument may look like one of this tool's flags (--quiet).
  e.slurm.sbatch_args = args.options("--sbatch-arg");
  e.slurm.partition = args.option("--partition", "");
  e.site = args.option("--site", "");
  e.join = args.flag("--join");
  e.executor = args.option("--executor", "local");
  e.wait = !args.flag("--no-wait");
  const unsigned cores = std::thread::hardware_concurrency();
  e.jobs = static_cast<int>(args.integer("--jobs", cores > 0 ? cores : 1));
  if (e.jobs < 1) throw cli::UsageError("--jobs: at least 1");
  if (e.executor != "local" && e.executor != "slurm")
    throw cli::UsageError("--executor: local or slurm, got '" + e.executor + "'");
  const bool slurm_options = !e.slurm.sbatch_args.empty() || !e.slurm.partition.empty() || !e.wait;
  if (e.executor != "slurm" && slurm_options)
    throw cli::UsageError("--partition, --sbatch-arg and --no-wait go with --executor slurm");
  if ((!e.site.empty() || e.join) && (e.executor != "local" || slurm_options))
    throw cli::UsageError("--site and --join run here: no --executor with them");
  if (!e.site.empty() && e.join) throw cli::UsageError("give --site K or --join, not both");
  return e;
}

// --site K: 1-based index or site id.
std::size_t siteIndex(const Traverse& t, const std::string& site) {
  if (site.find_first_not_of("0123456789") == std::string::npos) {
    const std::size_t k = std::stoul(site);
    if (k >= 1 && k <= t.sites.size()) return k - 1;
  }
  for (std::size_t k = 0; k < t.sites.size(); ++k)
    if (t.sites[k].id == site) return k;
  throw cli::InputError(t.root + "/traverse.json", "sites",
                        "no site '" + site + "' (1.." + std::to_string(t.sites.size()) + " or a site id)");
}

int printResult(const traverse::TraverseResult& r, const std::string& out_dir) {
  int mapped = 0;
  for (const traverse::SiteOutcome& s : r.sites) mapped += s.ok ? 1 : 0;
  std::printf("traverse: %d of %zu sites mapped, %zu files in %s\n", mapped, r.sites.size(), r.files.size(),
              out_dir.c_str());
  for (const std::string& e : r.write_errors)
    std::fprintf(stderr, "areomap-traverse: error: not written: %s\n", e.c_str());
  return r.write_errors.empty() ? 0 : 1;
}

// The command line that goes on from the complete sites: this one with --resume.
std::string resumeCommand(const std::vector<std::string>& argv) {
  std::vector<std::string> line = argv;
  if (std::find(line.begin(), line.end(), "--resume") == line.end()) line.push_back("--resume");
  line.erase(std::remove(line.begin(), line.end(), "--no-wait"), line.end());
  return traverse::shellLine(line);
}

int runOnSlurm(const Traverse& t, const traverse::TraverseCommand& command, const traverse::TraverseRunOptions& o,
               Execution& e, const std::vector<std::string>& argv) {
  e.slurm.progress = o.progress;
  traverse::SlurmRun run =
      traverse::submitTraverse(command, traverse::sitesToRun(t, o.out_dir, o.resume, o.progress), e.slurm);
  std::printf("slurm: sites job %s (%zu tasks), join job %s\n", run.sites_job.empty() ? "-" : run.sites_job.c_str(),
              run.sites.size(), run.join_job.c_str());
  std::fflush(stdout);
  if (!e.wait) {
    std::printf("slurm: the join job finishes the run with\n  %s\n", traverse::shellLine(command.join()).c_str());
    std::printf("slurm: if a task fails the join is cancelled; then, once the cause is fixed:\n  %s\n",
                resumeCommand(argv).c_str());
    return 0;
  }
  traverse::waitForTraverse(run, command, t, e.slurm);
  if (run.join_state == "COMPLETED") {
    const std::string summary = traverse::summaryFromReport(o.out_dir);
    std::printf("%s\n", summary.c_str());
    return summary.empty() ? 1 : 0;
  }
  if (run.failed.empty() && run.join_state != "CANCELLED") {
    std::fprintf(stderr, "areomap-traverse: error: the cross-site step (job %s) ended %s: %s\n",
                 run.join_job.c_str(), run.join_state.c_str(),
                 traverse::reasonFromLog(o.out_dir + "/logs/join.log").c_str());
    return 1;
  }
  traverse::reportFailedSites(t, o.out_dir, run.failed,
                              {{"name", "slurm"},
                               {"sites_job", run.sites_job},
                               {"join_job", run.join_job},
                               {"join_state", run.join_state + (run.join_reason.empty() ? "" : " (" + run.join_reason + ")")}},
                              resumeCommand(argv));
  return 1;
}

int runHere(const Traverse& t, const traverse::TraverseCommand& command, const traverse::TraverseRunOptions& o,
            const Execution& e, const std::vector<std::string>& argv) {
  const std::vector<std::size_t> sites = traverse::sitesToRun(t, o.out_dir, o.resume && !o.reuse_sites, false);
  if (e.jobs <= 1 || sites.size() <= 1 || o.reuse_sites) return printResult(traverse::runTraverse(t, o), o.out_dir);
  const std::vector<traverse::FailedSite> failed =
      traverse::runSitesLocally(command, t, sites, e.jobs, o.progress);
  if (!failed.empty()) {
    traverse::reportFailedSites(t, o.out_dir, failed, {{"name", "local"}, {"jobs", std::to_string(e.jobs)}},
                                resumeCommand(argv));
    return 1;
  }
  return printResult(traverse::joinTraverse(t, o), o.out_dir);
}

}  // namespace
}  // namespace areomap

int main(int argc, char** argv) {
  using namespace areomap;
  const std::vector<std::string> command_line(argv, argv + argc);
  return cli::runTool("areomap-traverse", argc, argv, kUsage, [&](cli::Args& args) {
    Execution e = execution(args);
    const traverse::TraverseRunOptions o = runOptions(args);
    const std::string dataset = args.positional(0, "DATASET");
    const Traverse t = readTraverse(dataset);
    checkTraverseSites(t);
    if (!e.site.empty()) {
      const traverse::SiteOutcome s = traverse::mapSite(t, siteIndex(t, e.site), o);
      std::printf("site %s: %s%s\n", s.id.c_str(), s.ok ? "mapped" : "not mapped: ", s.error.c_str());
      return 0;
    }
    if (e.join) return printResult(traverse::joinTraverse(t, o), o.out_dir);
    const traverse::TraverseCommand command = traverse::traverseCommand(cli::ownExecutable(), dataset, o);
    if (e.executor == "slurm") return runOnSlurm(t, command, o, e, command_line);
    return runHere(t, command, o, e, command_line);
  });
}
