// Other programs run by a tool: a command whose output is read (sbatch, squeue), and children that run
// beside each other with their output in a log file (areomap-traverse --jobs N). No shell: each argument
// is passed as it is; the program is looked up on PATH.
#pragma once

#include <string>
#include <vector>

namespace areomap::cli {

// How a program ended: its exit code, or the signal that ended it.
struct ProcessExit {
  int exit_code = -1;  // -1 when a signal ended it
  int signal = 0;
  bool ok() const { return exit_code == 0; }
  std::string describe() const;  // "exit 1", "killed by signal 9 (Killed)"
};

struct ProcessOutput {
  ProcessExit exit;
  std::string out;  // stdout and stderr, interleaved as written
};

// Runs `argv` to its end and returns its output. Throws InputError(argv[0], "command", ...) when it cannot
// be started (not on PATH).
ProcessOutput runProcess(const std::vector<std::string>& argv);

// Starts `argv` with stdout and stderr to `log_path` (created or truncated); returns its process id.
// Throws InputError when it cannot be started.
int startProcess(const std::vector<std::string>& argv, const std::string& log_path);

// Waits for a child of startProcess to end; returns its process id and how it ended (-1: no child).
int waitForChild(ProcessExit& exit);

// This program's own path (/proc/self/exe), to run it again for a part of its work.
std::string ownExecutable();

}  // namespace areomap::cli
