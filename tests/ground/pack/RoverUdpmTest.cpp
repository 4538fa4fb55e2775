// The rover as its own process over UDP multicast: this test publishes the tiny stream at full speed and
// listens to the rover's results, counting their sequence numbers (a test subscriber in place of the ground
// node). Runs in a private network namespace (unshare -n; loopback up; 239.0.0.0/8 routed to lo) so that it
// needs no multicast route and sees no other run; on the host network when no namespace can be made here;
// skipped with the reason printed only when neither works.
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "areomap/eo_solution_t.hpp"
#include "areomap/rover_status_t.hpp"
#include "areomap/tiepoints_t.hpp"
#include "firmware_core/base/Capacities.hpp"
#include "ground/dataset/Dataset.hpp"
#include "ground/pack/Pack.hpp"
#include "msgs/Channels.hpp"
#include "msgs/MessageCheck.hpp"
#include "platform/posix/LcmTransport.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

constexpr const char* kInNamespaceEnv = "AREOMAP_ROVER_UDPM_IN_NETNS";

struct Listener {
  std::vector<int64_t> tiepoint_sequences;
  rover_status_t status;
  int statuses = 0;
  std::vector<int64_t> status_sequences;
  std::vector<double> status_times_s;
  bool final_eo = false;
  static void onStatus(void* ctx, const char*, const uint8_t* data, std::size_t size) {
    auto* self = static_cast<Listener*>(ctx);
    if (ok(msgs::decodeMessage(data, size, self->status))) {
      self->statuses += 1;
      self->status_sequences.push_back(self->status.sequence);
      self->status_times_s.push_back(
          std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count());
    }
  }
  static void onTies(void* ctx, const char*, const uint8_t* data, std::size_t size) {
    tiepoints_t t;
    if (ok(msgs::decodeMessage(data, size, t))) static_cast<Listener*>(ctx)->tiepoint_sequences.push_back(t.sequence);
  }
  static void onEo(void* ctx, const char*, const uint8_t* data, std::size_t size) {
    eo_solution_t e;
    if (ok(msgs::decodeMessage(data, size, e)) && e.is_final) static_cast<Listener*>(ctx)->final_eo = true;
  }
};

std::string binDir() {
  const char* bin = std::getenv("AREOMAP_BINARY_DIR");
  return std::string(bin != nullptr ? bin : ".") + "/bin";
}

// The tiny dataset's stream; the dataset is the other tests' here (test::makeTinyDataset).
std::vector<LogEvent> tinyEvents() {
  const std::string dir = test::makeTinyDataset("rover-udpm");
  CHECK(!dir.empty());
  return packDataset(readDataset(dir), PackOptions{});
}

// Returns "" on success, else why it failed; `no_network` when nothing could be exchanged at all.
std::string runRover(bool& no_network) {
  no_network = false;
  const int port = 20000 + static_cast<int>(getpid() % 20000);
  const std::string url = "udpm://239.255.76.67:" + std::to_string(port);
  platform::LcmTransport lcm;
  if (!ok(lcm.open(url.c_str()))) {
    no_network = true;
    return "udpm did not open (" + url + ")";
  }
  Listener listener;
  CHECK_EQUAL(true, ok(lcm.subscribe(channels::kRoverStatus, &Listener::onStatus, &listener)));
  CHECK_EQUAL(true, ok(lcm.subscribe(channels::kTiePoints, &Listener::onTies, &listener)));
  CHECK_EQUAL(true, ok(lcm.subscribe(channels::kEoSolution, &Listener::onEo, &listener)));
  const std::vector<LogEvent> events = tinyEvents();
  const pid_t pid = fork();
  if (pid == 0) {
    const std::string rover = binDir() + "/areomap-rover";
    execl(rover.c_str(), rover.c_str(), "--lcm", url.c_str(), "--exit-at-end", "--quiet", "--max-seconds", "120",
          static_cast<char*>(nullptr));
    _exit(127);
  }
  // The rover's first heartbeat says it is listening.
  for (int i = 0; i < 100 && listener.statuses == 0; ++i) (void)lcm.handle(50);
  if (listener.statuses == 0) {
    kill(pid, SIGTERM);
    waitpid(pid, nullptr, 0);
    no_network = true;
    return "no heartbeat from the rover (no multicast route?)";
  }
  const auto start = std::chrono::steady_clock::now();
  for (const LogEvent& e : events) {
    if (!ok(lcm.publish(e.channel.c_str(), e.data.data(), e.data.size()))) return "publish failed";
  }
  const double publish_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (int i = 0; i < 1200 && !(listener.final_eo && listener.status.state == rover_status_t::STATE_FINISHED); ++i) {
    (void)lcm.handle(50);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const rover_status_t& s = listener.status;
  std::printf("rover over udpm: %zu messages published in %.3f s (%.0f msg/s); rover: seen %d accepted %d, gaps %d, "
              "duplicates %d, heap after init %lld, static %lld B; %zu tie-point messages back; %.2f s to the "
              "final EO; exit %d\n",
              events.size(), publish_s, events.size() / std::max(publish_s, 1e-6), s.pairs_seen, s.pairs_accepted,
              s.sequence_gaps, s.duplicates, static_cast<long long>(s.heap_allocs_after_init),
              static_cast<long long>(s.static_bytes), listener.tiepoint_sequences.size(), total_s,
              WIFEXITED(status) ? WEXITSTATUS(status) : -1);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) return "the rover did not exit 0";
  if (!listener.final_eo) return "no final EO solution";
  if (s.sequence_gaps != 0 || s.duplicates != 0) return "sequence gaps at the rover";
  if (s.pairs_accepted != static_cast<int>(events.size()) - 1) return "pairs lost";
  if (s.heap_allocs_after_init != 0) return "heap allocations after start-up in the pipeline";
  // The rover program's memory as it reports it: static buffers and the start-up reserve, within 64 MiB.
  if (s.static_bytes <= 0 || s.static_bytes > static_cast<int64_t>(kStaticMemoryBudgetBytes))
    return "the rover's memory (static and start-up reserve) is not within the 64 MiB budget";
  // The rover's own messages: tie points 0..n-1 without a gap.
  for (std::size_t i = 0; i < listener.tiepoint_sequences.size(); ++i) {
    if (listener.tiepoint_sequences[i] != static_cast<int64_t>(i)) return "gap in the rover's tie-point messages";
  }
  if (listener.tiepoint_sequences.size() != events.size() - 1) return "tie-point messages lost";
  // Status: one series without gaps or repeats, at least every ~1 s (the 1 Hz heartbeat) while working.
  double longest_s = 0.0;
  for (std::size_t i = 1; i < listener.status_sequences.size(); ++i) {
    if (listener.status_sequences[i] != listener.status_sequences[i - 1] + 1) return "status sequence broken";
    longest_s = std::max(longest_s, listener.status_times_s[i] - listener.status_times_s[i - 1]);
  }
  std::printf("rover status: %zu messages, longest interval %.2f s\n", listener.status_sequences.size(), longest_s);
  if (longest_s > 1.5) return "status heartbeat slower than 1 Hz";
  return "";
}

int runInNamespace(std::string& why) {
  if (std::system("unshare -n true >/dev/null 2>&1") != 0) {
    why = "unshare -n is not permitted here";
    return -1;
  }
  char self[4096] = {0};
  const ssize_t n = readlink("/proc/self/exe", self, sizeof(self) - 1);
  if (n <= 0) {
    why = "cannot find this test binary";
    return -1;
  }
  const std::string command = std::string("unshare -n sh -c 'ip link set lo up && ip route add 239.0.0.0/8 dev lo && ") +
                              kInNamespaceEnv + "=1 exec \"$0\" -sg RoverUdpm -sn TinyStreamFullSpeedNoGaps' '" +
                              self + "'";
  std::fflush(stdout);
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

}  // namespace

TEST_GROUP(RoverUdpm){};

// The tiny stream published at full speed to areomap-rover over udpm: every pair accepted, 0 sequence
// gaps, the rover's results all back, zero heap after start-up in the rover's pipeline, exit 0.
TEST(RoverUdpm, TinyStreamFullSpeedNoGaps) {
  bool no_network = false;
  if (std::getenv(kInNamespaceEnv) != nullptr) {
    const std::string failure = runRover(no_network);
    if (!failure.empty()) FAIL(failure.c_str());
    std::printf("rover udpm: ran in a private network namespace\n");
    return;
  }
  std::string why;
  const int status = runInNamespace(why);
  if (status >= 0) {
    CHECK_EQUAL(0, status);
    return;
  }
  const std::string failure = runRover(no_network);
  if (failure.empty()) {
    std::printf("rover udpm: ran on the host network (%s)\n", why.c_str());
    return;
  }
  if (!no_network) FAIL(failure.c_str());
  std::printf("SKIP rover udpm: %s; and on the host network: %s\n", why.c_str(), failure.c_str());
}
