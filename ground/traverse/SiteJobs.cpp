#include "ground/traverse/SiteJobs.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "ground/cli/AtomicFile.hpp"
#include "ground/cli/Cli.hpp"
#include "ground/cli/Process.hpp"
#include "ground/traverse/SiteManifest.hpp"

namespace areomap::traverse {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// A number as the command line gives it back exactly, in the fewest digits that do.
std::string exactNumber(double v) {
  char b[40];
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(b, sizeof b, "%.*g", digits, v);
    if (std::strtod(b, nullptr) == v) break;
  }
  return b;
}

// A site's running child (runSitesLocally).
struct SiteChild {
  std::size_t index;
  std::string log;
};

}  // namespace

std::vector<std::string> TraverseCommand::site(const std::string& site) const {
  std::vector<std::string> argv = {exe, dataset, "--out", out_dir, "--site", site};
  argv.insert(argv.end(), pass_args.begin(), pass_args.end());
  return argv;
}

std::vector<std::string> TraverseCommand::join() const {
  std::vector<std::string> argv = {exe, dataset, "--out", out_dir, "--join"};
  argv.insert(argv.end(), join_args.begin(), join_args.end());
  return argv;
}

TraverseCommand traverseCommand(const std::string& exe, const std::string& dataset, const TraverseRunOptions& o) {
  TraverseCommand c;
  c.exe = exe;
  c.dataset = dataset;
  c.out_dir = o.out_dir;
  if (!o.products) {
    c.pass_args.push_back("--no-products");
    c.join_args.push_back("--no-products");
  }
  if (o.cell_m > 0.0) c.join_args.insert(c.join_args.end(), {"--cell-m", exactNumber(o.cell_m)});
  if (!o.cross_ties_csv.empty()) {
    c.join_args.insert(c.join_args.end(), {"--cross-ties", o.cross_ties_csv});
  } else if (o.truth_cross_ties) {
    c.join_args.insert(c.join_args.end(), {"--truth-cross-ties", "--noise-px", exactNumber(o.truth_noise_px)});
  } else if (!o.match_cross_ties) {
    c.join_args.push_back("--no-cross-ties");
  }
  if (!o.progress) {
    c.pass_args.push_back("--quiet");
    c.join_args.push_back("--quiet");
  }
  return c;
}

std::string shellLine(const std::vector<std::string>& argv) {
  std::string line;
  for (const std::string& a : argv) {
    if (!line.empty()) line += ' ';
    const bool plain = !a.empty() && a.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                                         "0123456789_-+=./:,@%") == std::string::npos;
    if (plain) {
      line += a;
      continue;
    }
    line += '\'';
    for (char ch : a) line += ch == '\'' ? std::string("'\\''") : std::string(1, ch);
    line += '\'';
  }
  return line;
}

std::vector<std::size_t> sitesToRun(const Traverse& traverse, const std::string& out_dir, bool resume,
                                    bool progress) {
  std::vector<std::size_t> run;
  for (std::size_t k = 0; k < traverse.sites.size(); ++k) {
    const std::string id = traverse.sites[k].id;
    if (!resume) {
      run.push_back(k);
      continue;
    }
    const SiteRecord r = checkSiteManifest(out_dir + "/sites/" + id, id);
    if (r.complete && r.mapped) {
      if (progress) cli::info("site " + id + ": its pass is complete (--resume)");
      continue;
    }
    if (progress) cli::info("site " + id + ": to map again (" + (r.complete ? "it was not mapped" : r.why_not) + ")");
    run.push_back(k);
  }
  return run;
}

std::string siteLogPath(const std::string& out_dir, std::size_t k) {
  return out_dir + "/logs/site-" + std::to_string(k) + ".log";
}

std::string reasonFromLog(const std::string& log_path) {
  std::ifstream in(log_path);
  std::string line, last, last_error;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    last = line;
    if (line.find("error") != std::string::npos || line.find("CANCELLED") != std::string::npos) last_error = line;
  }
  return last_error.empty() ? last : last_error;
}

std::vector<FailedSite> runSitesLocally(const TraverseCommand& command, const Traverse& traverse,
                                        const std::vector<std::size_t>& sites, int jobs, bool progress) {
  fs::create_directories(command.out_dir + "/logs");
  std::map<int, SiteChild> running;
  std::vector<FailedSite> failed;
  std::size_t next = 0, ended = 0;
  while (ended < sites.size()) {
    while (next < sites.size() && static_cast<int>(running.size()) < std::max(1, jobs)) {
      const std::size_t k = sites[next++];
      const std::string log = siteLogPath(command.out_dir, k + 1);
      const int pid = cli::startProcess(command.site(std::to_string(k + 1)), log);
      running[pid] = {k, log};
      if (progress) cli::info("site " + traverse.sites[k].id + ": started (log " + log + ")");
    }
    cli::ProcessExit exit;
    const int pid = cli::waitForChild(exit);
    const auto it = running.find(pid);
    if (it == running.end()) continue;  // not one of ours
    const SiteChild child = it->second;
    running.erase(it);
    ++ended;
    const std::string& id = traverse.sites[child.index].id;
    if (exit.ok()) {
      if (progress)
        cli::info("site " + id + ": done (" + std::to_string(ended) + " of " + std::to_string(sites.size()) + ")");
      continue;
    }
    failed.push_back({child.index, id, "local", exit.describe(), reasonFromLog(child.log)});
    cli::warn("site " + id + ": its pass failed (" + exit.describe() + "): " + failed.back().reason);
  }
  std::sort(failed.begin(), failed.end(), [](const FailedSite& a, const FailedSite& b) { return a.index < b.index; });
  return failed;
}

void reportFailedSites(const Traverse& traverse, const std::string& out_dir, const std::vector<FailedSite>& failed,
                       const std::map<std::string, std::string>& executor, const std::string& resume_command) {
  json sites = json::array();
  for (std::size_t k = 0; k < traverse.sites.size(); ++k) {
    const std::string& id = traverse.sites[k].id;
    json s = {{"id", id}};
    const auto f = std::find_if(failed.begin(), failed.end(), [&](const FailedSite& x) { return x.index == k; });
    if (f != failed.end()) {
      s["mapped"] = false;
      s["job_failed"] = {{"job", f->job}, {"state", f->state}, {"reason", f->reason}};
    } else {
      const SiteRecord r = checkSiteManifest(out_dir + "/sites/" + id, id);
      s["mapped"] = r.complete && r.mapped;
      if (!r.complete) s["incomplete"] = r.why_not;
      if (r.complete && !r.mapped) s["error"] = r.error;
    }
    sites.push_back(s);
  }
  json exec = json::object();
  for (const auto& [key, value] : executor) exec[key] = value;
  json report = {{"status", "incomplete"},
                 {"executor", exec},
                 {"traverse", {{"sites", static_cast<int>(traverse.sites.size())}, {"site", sites}}},
                 {"resume", resume_command},
                 {"warnings", json::array()}};
  for (const FailedSite& f : failed) {
    const std::string line = "site " + f.id + " (job " + f.job + ") failed: " + f.state + ": " + f.reason;
    report["warnings"].push_back(line);
    std::fprintf(stderr, "areomap-traverse: error: %s\n", line.c_str());
  }
  report["warnings"].push_back("The cross-site step did not run. Once the cause is fixed, " + resume_command +
                               " maps the failed sites again and finishes the run.");
  cli::writeFileAtomic(out_dir + "/report.json", report.dump(1) + "\n");
  std::fprintf(stderr,
               "areomap-traverse: the cross-site step did not run (%s/report.json); once the cause is fixed:\n  %s\n",
               out_dir.c_str(), resume_command.c_str());
}

std::string summaryFromReport(const std::string& out_dir) {
  std::ifstream in(out_dir + "/report.json");
  const json r = json::parse(in, nullptr, false);
  if (r.is_discarded() || !r.contains("traverse") || !r["traverse"].contains("site")) return "";
  int mapped = 0, sites = 0;
  for (const json& s : r["traverse"]["site"]) {
    ++sites;
    mapped += s.value("mapped", false) ? 1 : 0;
  }
  return "traverse: " + std::to_string(mapped) + " of " + std::to_string(sites) + " sites mapped in " + out_dir;
}

}  // namespace areomap::traverse
