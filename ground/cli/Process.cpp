#include "ground/cli/Process.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "ground/cli/Cli.hpp"

extern char** environ;

namespace areomap::cli {

namespace {

ProcessExit exitOf(int status) {
  ProcessExit e;
  if (WIFEXITED(status)) {
    e.exit_code = WEXITSTATUS(status);
  } else if (WIFSIGNALED(status)) {
    e.signal = WTERMSIG(status);
  }
  return e;
}

// posix_spawnp with `actions`; throws when the program cannot be started.
pid_t spawnWith(const std::vector<std::string>& argv, posix_spawn_file_actions_t* actions) {
  if (argv.empty()) throw InputError("", "command", "empty command line");
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, args[0], actions, nullptr, args.data(), environ);
  if (rc != 0) throw InputError(argv[0], "command", std::string("cannot be started: ") + std::strerror(rc));
  return pid;
}

}  // namespace

std::string ProcessExit::describe() const {
  if (exit_code >= 0) return "exit " + std::to_string(exit_code);
  return "killed by signal " + std::to_string(signal) + " (" + strsignal(signal) + ")";
}

ProcessOutput runProcess(const std::vector<std::string>& argv) {
  int fds[2];
  if (pipe(fds) != 0) throw InputError(argv.empty() ? "" : argv[0], "command", "no pipe for its output");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addclose(&actions, fds[0]);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDERR_FILENO);
  posix_spawn_file_actions_addclose(&actions, fds[1]);
  pid_t pid = -1;
  try {
    pid = spawnWith(argv, &actions);
  } catch (...) {
    posix_spawn_file_actions_destroy(&actions);
    close(fds[0]);
    close(fds[1]);
    throw;
  }
  posix_spawn_file_actions_destroy(&actions);
  close(fds[1]);
  ProcessOutput result;
  char buffer[4096];
  for (;;) {
    const ssize_t n = read(fds[0], buffer, sizeof buffer);
    if (n > 0) {
      result.out.append(buffer, static_cast<std::size_t>(n));
    } else if (n == 0 || errno != EINTR) {
      break;
    }
  }
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  result.exit = exitOf(status);
  return result;
}

int startProcess(const std::vector<std::string>& argv, const std::string& log_path) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  try {
    const pid_t pid = spawnWith(argv, &actions);
    posix_spawn_file_actions_destroy(&actions);
    return static_cast<int>(pid);
  } catch (...) {
    posix_spawn_file_actions_destroy(&actions);
    throw;
  }
}

int waitForChild(ProcessExit& exit) {
  int status = 0;
  pid_t pid;
  while ((pid = waitpid(-1, &status, 0)) < 0 && errno == EINTR) {
  }
  if (pid > 0) exit = exitOf(status);
  return static_cast<int>(pid);
}

std::string ownExecutable() {
  std::error_code ec;
  const std::filesystem::path p = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) throw InputError("/proc/self/exe", "", "cannot find this program's own path: " + ec.message());
  return p.string();
}

}  // namespace areomap::cli
