// A traverse's site passes as separate jobs (areomap-traverse --jobs N, --executor slurm): each site's pass
// is the command a user could type for that one site, `areomap-traverse DATASET --out DIR --site K`, which
// maps the site into DIR/sites/<id>/ and ends with its manifest (SiteManifest.hpp); once every site's job
// has ended well, the cross-site step runs on what they wrote, `areomap-traverse DATASET --out DIR --join`
// (TraverseRun.hpp joinTraverse). A site whose pass fails for its data is a job that ended well (the
// manifest says why the site is not mapped, and the join reports it); a job that fails (killed, its
// folder not writable) keeps the join from running, and DIR/report.json says which site failed and why.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "ground/dataset/Traverse.hpp"
#include "ground/traverse/TraverseRun.hpp"

namespace areomap::traverse {

// The command lines of the jobs. DATASET and DIR are kept as the user gave them: every job runs in the
// working folder of the run that started it.
struct TraverseCommand {
  std::string exe;  // areomap-traverse (absolute)
  std::string dataset;
  std::string out_dir;
  std::vector<std::string> pass_args;  // the options of a site's pass (--no-products, --quiet)
  std::vector<std::string> join_args;  // the options of the cross-site step
  // `exe DATASET --out DIR --site SITE pass_args...`; SITE is a 1-based index or a site id.
  std::vector<std::string> site(const std::string& site) const;
  std::vector<std::string> join() const;
};

TraverseCommand traverseCommand(const std::string& exe, const std::string& dataset, const TraverseRunOptions& o);

// The command as one line for a POSIX shell (arguments quoted where needed).
std::string shellLine(const std::vector<std::string>& argv);

// The sites (0-based, in order) whose pass is to run: every site, or with `resume` those without a
// complete pass of a mapped site (checkSiteManifest; each one said on the console with `progress`).
std::vector<std::size_t> sitesToRun(const Traverse& traverse, const std::string& out_dir, bool resume,
                                    bool progress);

// A site job's log: OUT/logs/site-<k>.log, k 1-based (Slurm's %a of the array task).
std::string siteLogPath(const std::string& out_dir, std::size_t k);

// The line of a job's log that says why it failed: its last line that reports an error, else its last line
// ("" without a log).
std::string reasonFromLog(const std::string& log_path);

// A site's job that did not end well.
struct FailedSite {
  std::size_t index = 0;  // 0-based
  std::string id;
  std::string job;     // "local", or the Slurm array task ("123_2")
  std::string state;   // "exit 1", "killed by signal 9 (Killed)", Slurm's "FAILED", "CANCELLED", ...
  std::string reason;  // from the job's log
};

// Runs the sites' passes as child processes, `jobs` at a time, each with its output in siteLogPath; returns
// the sites whose child failed.
std::vector<FailedSite> runSitesLocally(const TraverseCommand& command, const Traverse& traverse,
                                        const std::vector<std::size_t>& sites, int jobs, bool progress);

// DIR/report.json of a run whose cross-site step did not run because site jobs failed: "status":
// "incomplete", each site's state (mapped, not mapped for its data, or its failed job with the reason),
// `executor` (name and job ids) and the command that goes on from the complete sites. Also on stderr.
void reportFailedSites(const Traverse& traverse, const std::string& out_dir, const std::vector<FailedSite>& failed,
                       const std::map<std::string, std::string>& executor, const std::string& resume_command);

// "traverse: M of N sites mapped ..." from DIR/report.json (a join run elsewhere); the line, or "" when
// report.json cannot be read.
std::string summaryFromReport(const std::string& out_dir);

}  // namespace areomap::traverse
