// areomap-traverse --executor slurm: the sites' passes as one Slurm job array and the cross-site step as
// one job after it (SiteJobs.hpp for the commands they run). Every site's pass is an array task running
// `areomap-traverse DATASET --out DIR --site $SLURM_ARRAY_TASK_ID`; the join runs `... --join` with
// `--dependency=afterok:<array>` and `--kill-on-invalid-dep=yes`, so that a failed task cancels it instead
// of leaving it pending for ever. The tool talks to Slurm only through its commands (sbatch, squeue,
// sacct, scontrol): whatever cluster they reach (SLURM_CONF, the site's slurm.conf) runs the jobs, and DIR
// is the storage every node shares.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "ground/dataset/Traverse.hpp"
#include "ground/traverse/SiteJobs.hpp"

namespace areomap::traverse {

struct SlurmOptions {
  std::string partition;                 // "" : the cluster's default
  std::vector<std::string> sbatch_args;  // given to both sbatch calls after the tool's own options
  bool progress = true;
  // Between two squeue calls while waiting: from poll_s after a change up to poll_max_s while nothing
  // changes (a cluster's controller is shared).
  double poll_s = 1.0;
  double poll_max_s = 15.0;
};

struct SlurmRun {
  std::string sites_job;  // the array's job id ("" when no site had to run)
  std::string join_job;
  std::vector<std::size_t> sites;  // 0-based, the array's tasks are these + 1
  // After waitForTraverse:
  std::string join_state;  // COMPLETED, CANCELLED, FAILED, ... (Slurm's words; "UNKNOWN" when it forgot)
  std::string join_reason;
  std::vector<FailedSite> failed;  // the tasks that did not complete
};

// Submits the array (the `sites`, 0-based; none: no array) and the join; throws InputError("sbatch", ...)
// with sbatch's message when a submission is refused.
SlurmRun submitTraverse(const TraverseCommand& command, const std::vector<std::size_t>& sites,
                        const SlurmOptions& options);

// Waits until the join and every task have ended, a progress line on stderr whenever the counts change
// (squeue; sacct once squeue has forgotten the jobs). Fills join_state and, for every task that did not
// complete, its state, exit code (scontrol) and the reason its log gives.
void waitForTraverse(SlurmRun& run, const TraverseCommand& command, const Traverse& traverse,
                     const SlurmOptions& options);

}  // namespace areomap::traverse
