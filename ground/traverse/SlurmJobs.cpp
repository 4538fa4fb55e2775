#include "ground/traverse/SlurmJobs.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <thread>

#include "ground/cli/Cli.hpp"
#include "ground/cli/Process.hpp"
#include "ground/traverse/SiteManifest.hpp"

namespace areomap::traverse {

namespace fs = std::filesystem;

namespace {

// Slurm's job states after which a job does not run again.
bool slurmFinal(const std::string& state) {
  static const std::set<std::string> kFinal = {"COMPLETED", "FAILED",        "CANCELLED", "TIMEOUT",
                                                "NODE_FAIL", "OUT_OF_MEMORY", "PREEMPTED", "BOOT_FAIL",
                                                "DEADLINE",  "REVOKED",       "UNKNOWN"};
  return kFinal.count(state) > 0;
}

// "1-3,5,7-8" for the 1-based tasks of `sites`.
std::string arraySpec(const std::vector<std::size_t>& sites) {
  std::string spec;
  for (std::size_t i = 0; i < sites.size();) {
    std::size_t j = i;
    while (j + 1 < sites.size() && sites[j + 1] == sites[j] + 1) ++j;
    if (!spec.empty()) spec += ',';
    spec += std::to_string(sites[i] + 1);
    if (j > i) spec += "-" + std::to_string(sites[j] + 1);
    i = j + 1;
  }
  return spec;
}

// sbatch --parsable ARGS: the job id ("123" of "123" or "123;cluster").
std::string sbatch(const std::vector<std::string>& args) {
  std::vector<std::string> argv = {"sbatch", "--parsable"};
  argv.insert(argv.end(), args.begin(), args.end());
  const cli::ProcessOutput r = cli::runProcess(argv);
  std::string id = r.out.substr(0, r.out.find_first_of(";\n"));
  if (!r.exit.ok() || id.empty() || id.find_first_not_of("0123456789") != std::string::npos)
    throw cli::InputError("sbatch", "command", "refused the job (" + r.exit.describe() + "): " + r.out);
  return id;
}

// The states of the jobs (`ids`: "A,J") by job id, an array task as "A_K": from squeue (jobs Slurm still
// holds), else from sacct (the accounting database, where there is one). Empty when neither knows them.
std::map<std::string, std::pair<std::string, std::string>> jobStates(const std::string& ids) {
  std::map<std::string, std::pair<std::string, std::string>> states;
  cli::ProcessOutput r = cli::runProcess(
      {"squeue", "--noheader", "--array", "--states=all", "--jobs=" + ids, "--format=%i|%T|%r"});
  if (!r.exit.ok() || r.out.empty())
    r = cli::runProcess({"sacct", "--noheader", "--parsable2", "--allocations", "--jobs=" + ids,
                         "--format=JobID,State,Reason"});
  if (!r.exit.ok()) return states;
  std::istringstream lines(r.out);
  for (std::string line; std::getline(lines, line);) {
    std::istringstream fields(line);
    std::string id, state, reason;
    if (!std::getline(fields, id, '|') || !std::getline(fields, state, '|')) continue;
    std::getline(fields, reason);
    state = state.substr(0, state.find(' '));  // sacct: "CANCELLED by 0"
    states[id] = {state, reason};
  }
  return states;
}

// "exit 1" / "signal 9" of an ended job (scontrol's ExitCode=code:signal), "" when Slurm no longer knows it.
std::string exitOf(const std::string& job) {
  const cli::ProcessOutput r = cli::runProcess({"scontrol", "show", "job", job});
  const std::size_t at = r.out.find(" ExitCode=");
  if (!r.exit.ok() || at == std::string::npos) return "";
  const std::string code = r.out.substr(at + 10, r.out.find_first_of(" \n", at + 10) - at - 10);
  const std::size_t colon = code.find(':');
  if (colon == std::string::npos) return "";
  const std::string signal = code.substr(colon + 1);
  return signal != "0" ? "signal " + signal : "exit " + code.substr(0, colon);
}

}  // namespace

SlurmRun submitTraverse(const TraverseCommand& command, const std::vector<std::size_t>& sites,
                        const SlurmOptions& o) {
  std::error_code ec;
  fs::create_directories(command.out_dir + "/logs", ec);
  if (ec) throw cli::InputError(command.out_dir + "/logs", "--out", "cannot create the folder: " + ec.message());
  const std::string logs = fs::absolute(command.out_dir + "/logs").lexically_normal().string();
  std::vector<std::string> common;
  if (!o.partition.empty()) common.push_back("--partition=" + o.partition);
  SlurmRun run;
  run.sites = sites;
  if (!sites.empty()) {
    // The task's site is its array index: the shell of the batch script expands it.
    std::string line = shellLine(command.site("SITE_INDEX"));
    line.replace(line.find(" --site SITE_INDEX"), 18, " --site \"$SLURM_ARRAY_TASK_ID\"");
    std::vector<std::string> args = common;
    args.insert(args.end(), {"--job-name=areomap-sites", "--array=" + arraySpec(sites),
                             "--output=" + logs + "/site-%a.log"});
    args.insert(args.end(), o.sbatch_args.begin(), o.sbatch_args.end());
    args.push_back("--wrap=exec " + line);
    run.sites_job = sbatch(args);
  }
  std::vector<std::string> args = common;
  args.insert(args.end(), {"--job-name=areomap-join", "--output=" + logs + "/join.log"});
  if (!run.sites_job.empty())
    args.insert(args.end(), {"--dependency=afterok:" + run.sites_job, "--kill-on-invalid-dep=yes"});
  args.insert(args.end(), o.sbatch_args.begin(), o.sbatch_args.end());
  args.push_back("--wrap=exec " + shellLine(command.join()));
  run.join_job = sbatch(args);
  return run;
}

void waitForTraverse(SlurmRun& run, const TraverseCommand& command, const Traverse& traverse,
                     const SlurmOptions& o) {
  const std::string ids = run.sites_job.empty() ? run.join_job : run.sites_job + "," + run.join_job;
  std::map<std::string, std::pair<std::string, std::string>> states;
  std::string last_line;
  double pause_s = o.poll_s;
  for (;;) {
    states = jobStates(ids);
    int done = 0, running = 0, pending = 0, failed = 0;
    bool tasks_ended = true;
    for (std::size_t k : run.sites) {
      const auto it = states.find(run.sites_job + "_" + std::to_string(k + 1));
      const std::string state = it == states.end() ? "UNKNOWN" : it->second.first;
      done += state == "COMPLETED";
      running += state == "RUNNING" || state == "COMPLETING" || state == "CONFIGURING";
      pending += state == "PENDING" || state == "REQUEUED" || state == "SUSPENDED";
      failed += slurmFinal(state) && state != "COMPLETED";
      tasks_ended = tasks_ended && slurmFinal(state);
    }
    const auto join = states.find(run.join_job);
    run.join_state = join == states.end() ? "UNKNOWN" : join->second.first;
    run.join_reason = join == states.end() ? "" : join->second.second;
    const std::string line = "slurm: sites " + std::to_string(done) + " done, " + std::to_string(running) +
                             " running, " + std::to_string(pending) + " pending, " + std::to_string(failed) +
                             " failed of " + std::to_string(run.sites.size()) + "; join " + run.join_state +
                             (run.join_reason.empty() || run.join_reason == "None" ? "" : " (" + run.join_reason + ")");
    if (o.progress && line != last_line) cli::info(line);
    pause_s = line != last_line ? o.poll_s : std::min(o.poll_max_s, pause_s * 1.25);
    last_line = line;
    if (tasks_ended && slurmFinal(run.join_state)) break;
    std::this_thread::sleep_for(std::chrono::duration<double>(pause_s));
  }
  for (std::size_t k : run.sites) {
    const std::string task = run.sites_job + "_" + std::to_string(k + 1);
    const auto it = states.find(task);
    const std::string state = it == states.end() ? "UNKNOWN" : it->second.first;
    if (state == "COMPLETED") continue;
    // A task Slurm has forgotten (no accounting database) completed when its site's manifest says so.
    const std::string& id = traverse.sites[k].id;
    if (state == "UNKNOWN" && checkSiteManifest(command.out_dir + "/sites/" + id, id).complete) continue;
    const std::string code = exitOf(task);
    run.failed.push_back({k, id, task, code.empty() ? state : state + ", " + code,
                          reasonFromLog(siteLogPath(command.out_dir, k + 1))});
  }
}

}  // namespace areomap::traverse
