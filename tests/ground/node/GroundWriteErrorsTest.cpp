// areomap-ground exits 1 when a product cannot be written (DESIGN.md exit codes), naming the file,
// while the other products are still made and none is left half-written: the real binary in a child
// process, (1) on a dataset folder under a file-size limit (RLIMIT_FSIZE, SIGXFSZ ignored: write() fails
// with EFBIG as on a full disk), (2) re-making a recorded stream (file://) into a folder where one
// product's place is taken by a folder (not writable, also for root).
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "ground/dataset/Dataset.hpp"
#include "ground/io/CameraFile.hpp"
#include "ground/node/EventRecorder.hpp"
#include "tests/ground/dataset/FileSizeLimit.hpp"
#include "tests/ground/pack/TinyStream.hpp"
#include "tests/support/TestData.hpp"

#include <CppUTest/TestHarness.h>

using namespace areomap;

namespace {

const std::string& writeErrorsDataset() {
  static const std::string dir = test::makeTinyDataset("ground-write-errors");
  CHECK(!dir.empty());
  return dir;
}

// Runs bin/areomap-ground with `args`; its files limited to `fsize_limit` bytes (0: no limit), stderr into
// `err_path`. Returns the exit code, 128 + signal when it was killed.
int runGround(const std::vector<std::string>& args, rlim_t fsize_limit, const std::string& err_path) {
  const std::string bin = test::toolPath("areomap-ground");
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int err = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int null = ::open("/dev/null", O_WRONLY);
    if (err < 0 || null < 0) ::_exit(120);
    ::dup2(null, 1);
    ::dup2(err, 2);
    if (fsize_limit > 0) {
      static test::FileSizeLimit limit(fsize_limit);  // the limit and the ignored SIGXFSZ are kept across exec
    }
    std::vector<char*> argv{const_cast<char*>(bin.c_str())};
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(bin.c_str(), argv.data());
    ::_exit(121);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// Every adjusted model is there and parses (complete), for every image of the dataset.
void checkModels(const std::string& out, const Dataset& d) {
  for (const Pair& p : d.pairs) {
    for (const ImageRef* ref : {&p.left, p.right ? &*p.right : nullptr}) {
      if (ref == nullptr) continue;
      const std::string path = out + "/models/" + ref->stem + ".cahvor";
      CHECK_TEXT(test::fileExists(path), path.c_str());
      (void)io::readCameraModelFile(path);
    }
  }
}

}  // namespace

TEST_GROUP(GroundWriteErrors){};

// --dataset under a 16 KiB file-size limit: tiepoints.csv (~100 KB on tiny) cannot be written; exit 1 and
// stderr names it; the models, eo.csv and report.json are made; no temporary is left. The same run without
// the limit exits 0 (the limit is what fails).
TEST(GroundWriteErrors, DatasetFullDiskExitsOneNamingTheFile) {
  const Dataset d = readDataset(writeErrorsDataset());
  const std::string dir = test::scratchDir("ground-write-errors-full");
  const std::string out = dir + "/out", err = dir + "/stderr.txt";
  const int code =
      runGround({"--dataset", writeErrorsDataset(), "--out", out, "--no-products"}, 16 * 1024, err);
  const std::string text = test::fileBytes(err);
  std::printf("\nareomap-ground under a 16 KiB file-size limit: exit %d; stderr tail:\n%s\n", code,
              text.substr(text.size() > 600 ? text.size() - 600 : 0).c_str());
  CHECK_EQUAL(1, code);
  CHECK(contains(text, "error: not written: " + out + "/tiepoints.csv: cannot write"));
  CHECK(contains(text, "product file(s) could not be written; the other products were made"));
  CHECK(!test::fileExists(out + "/tiepoints.csv"));
  checkModels(out, d);
  CHECK(test::fileExists(out + "/eo.csv"));
  CHECK(test::fileExists(out + "/report.json"));
  CHECK(test::temporariesIn(out).empty());
  const std::string ok_out = dir + "/out-unlimited";
  CHECK_EQUAL(0, runGround({"--dataset", writeErrorsDataset(), "--out", ok_out, "--no-products"}, 0,
                           dir + "/stderr-ok.txt"));
  CHECK(test::fileExists(ok_out + "/tiepoints.csv"));
}

// The stream mode (a recorded camera stream re-made with --lcm file://) into a folder where eo.csv's place
// is taken by a folder: exit 1 naming eo.csv; the other products are made.
TEST(GroundWriteErrors, StreamUnwritableProductExitsOne) {
  const Dataset d = readDataset(writeErrorsDataset());
  const std::string dir = test::scratchDir("ground-write-errors-stream");
  const std::string log = dir + "/stream.lcm", out = dir + "/out", err = dir + "/stderr.txt";
  {
    ground::EventRecorder recorder;
    recorder.open(log);
    for (const LogEvent& e : test::packedStream(writeErrorsDataset())) {
      recorder.record(e.channel.c_str(), e.data.data(), e.data.size());
    }
  }
  std::filesystem::create_directories(out + "/eo.csv/blocked");
  const int code = runGround({"--lcm", "file://" + log, "--out", out, "--no-products", "--rover-wait-s", "0"}, 0, err);
  const std::string text = test::fileBytes(err);
  std::printf("\nareomap-ground --lcm file:// with eo.csv not writable: exit %d\n", code);
  CHECK_EQUAL(1, code);
  CHECK(contains(text, "error: not written: " + out + "/eo.csv"));
  checkModels(out, d);
  CHECK(test::fileExists(out + "/tiepoints.csv"));
  CHECK(test::fileExists(out + "/report.json"));
  CHECK(test::temporariesIn(out).empty());
}
