// areomap-rover ends within seconds on SIGTERM (a rover under qemu must not run on for minutes after it).
// The tool runs as a child process (in a cross build under the target's emulator, AREOMAP_TEST_EMULATOR)
// replaying file://FIFO, a named pipe whose writer (this test) stays silent: without the signal the rover
// would wait for its input for ever. Runs on every target (the file:// replay needs no LCM runtime).
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <initializer_list>
#include <sstream>
#include <string>
#include <thread>

#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

namespace {

using Clock = std::chrono::steady_clock;

std::string binaryDir() {
  const char* env = std::getenv("AREOMAP_BINARY_DIR");
  if (env != nullptr) return env;
  char exe[4096] = {0};
  const ssize_t n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
  std::string path = n > 0 ? std::string(exe, static_cast<std::size_t>(n)) : std::string("tests/x");
  path = path.substr(0, path.rfind('/'));  // <build>/tests
  return path.substr(0, path.rfind('/'));
}

std::string readText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// The rover on file://FIFO with a silent writer. pid is -1 when it did not start listening within a
// minute (start-up under qemu takes a few seconds).
struct RoverProcess {
  pid_t pid = -1;
  int writer = -1;
  std::string err_path;

  explicit RoverProcess(const std::string& name) {
    const std::string dir = areomap::test::scratchDir(name);
    const std::string fifo = dir + "/stream.lcm";
    err_path = dir + "/rover.err";
    if (mkfifo(fifo.c_str(), 0600) != 0) return;
    writer = open(fifo.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);  // keeps the pipe open, writes nothing
    const std::string rover = binaryDir() + "/bin/areomap-rover";
    pid = fork();
    if (pid == 0) {
      const int fd = open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
      // detect_leaks=0: in an ASan build LeakSanitizer's exit-time scan of the rover's ~65 MiB of static memory
      // takes ~5 s, which is not the exit time this test bounds (ignored by other builds).
      execl("/bin/sh", "sh", "-c",
            "ASAN_OPTIONS=\"${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0\"; export ASAN_OPTIONS; "
            "exec ${AREOMAP_TEST_EMULATOR:-} \"$0\" --lcm \"file://$1\" --quiet",
            rover.c_str(), fifo.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    const Clock::time_point start = Clock::now();
    while (secondsSince(start) < 60.0 && readText(err_path).find("listening on") == std::string::npos) {
      int status = 0;
      if (waitpid(pid, &status, WNOHANG) == pid) {
        pid = -1;
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    if (readText(err_path).find("listening on") == std::string::npos) stop();
  }
  ~RoverProcess() {
    stop();
    if (writer >= 0) close(writer);
  }
  RoverProcess(const RoverProcess&) = delete;
  RoverProcess& operator=(const RoverProcess&) = delete;

  // Writes 10 bytes of a 28-byte event header: the rover's read of the rest waits (and restarts after a
  // signal). True when written.
  bool stallInsideAnEvent() const {
    const unsigned char partial_header[10] = {0xED, 0xA1, 0xDA, 0x01, 0, 0, 0, 0, 0, 0};
    const bool written = write(writer, partial_header, sizeof(partial_header)) == 10;
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    return written;
  }

  // Waits up to `seconds` for the process to end: its wait status, or -1 (then it is SIGKILLed).
  int waitForExit(double seconds, double& took) {
    const Clock::time_point start = Clock::now();
    int status = 0;
    while (secondsSince(start) < seconds) {
      if (waitpid(pid, &status, WNOHANG) == pid) {
        took = secondsSince(start);
        pid = -1;
        return status;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    took = secondsSince(start);
    stop();
    return -1;
  }

  void stop() {
    if (pid <= 0) return;
    kill(pid, SIGKILL);
    int status = 0;
    waitpid(pid, &status, 0);
    pid = -1;
  }
};

// Sends `signals` (300 ms apart) to the rover and checks that it exits with `code` between min_s and max_s
// seconds after the last one, its stderr saying `said`.
void checkStopsOn(RoverProcess& rover, std::initializer_list<int> signals, int code, double min_s, double max_s,
                  const char* said) {
  CHECK_TEXT(rover.pid > 0, ("the rover did not start: " + readText(rover.err_path)).c_str());
  bool first = true;
  for (const int sig : signals) {
    if (!first) std::this_thread::sleep_for(std::chrono::milliseconds(300));
    first = false;
    CHECK_EQUAL(0, kill(rover.pid, sig));
  }
  double took = 0.0;
  const int status = rover.waitForExit(20.0, took);
  std::printf("rover: exit %d in %.2f s after the last signal\n", WIFEXITED(status) ? WEXITSTATUS(status) : -1, took);
  CHECK_TEXT(status != -1, "the rover ran on for 20 s after the signal");
  CHECK_TRUE(WIFEXITED(status));
  CHECK_EQUAL(code, WEXITSTATUS(status));
  CHECK(took >= min_s && took < max_s);
  CHECK_TEXT(readText(rover.err_path).find(said) != std::string::npos, readText(rover.err_path).c_str());
}

}  // namespace

TEST_GROUP(RoverSignal){};

// Waiting for input, SIGTERM ends the rover at once (the replay's handle() times out every 20 ms, so the
// transport loop sees the stop request) with exit 0 and its summary.
TEST(RoverSignal, SigtermEndsAWaitingRoverWithinSeconds) {
  RoverProcess rover("rover-sigterm");
  checkStopsOn(rover, {SIGTERM}, 0, 0.0, 3.0, "pairs seen 0");
}

// Stuck inside an event (the writer sent 10 bytes of a 28-byte event header, and read() restarts after a
// signal), SIGTERM still ends the rover: the watchdog the handler arms exits with 1 within its 6 s.
TEST(RoverSignal, SigtermEndsAStuckRoverThroughTheWatchdog) {
  RoverProcess rover("rover-stuck");
  CHECK_TRUE(rover.stallInsideAnEvent());
  checkStopsOn(rover, {SIGTERM}, 1, 4.0, 10.0, "not honoured within the watchdog time");
}

// A second signal exits at once, whatever the rover is doing.
TEST(RoverSignal, SecondSignalExitsAtOnce) {
  RoverProcess rover("rover-second-signal");
  CHECK_TRUE(rover.stallInsideAnEvent());
  checkStopsOn(rover, {SIGTERM, SIGINT}, 1, 0.0, 3.0, "second stop signal");
}
