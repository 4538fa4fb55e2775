#include "tests/support/TestData.hpp"

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace areomap::test {

std::string sourceDir() {
  const char* env = std::getenv("AREOMAP_SOURCE_DIR");
  return env != nullptr ? std::string(env) : std::string(AREOMAP_SOURCE_DIR);
}

std::string sharedDataDir() {
  const char* env = std::getenv("AREOMAP_SHARED_DATA");
  if (env != nullptr) return env;
  return sourceDir() + "/../shared/data";
}

std::string scratchPath(const std::string& name) {
  const char* env = std::getenv("AREOMAP_BINARY_DIR");
  return (env != nullptr ? std::string(env) : std::string(AREOMAP_BINARY_DIR)) + "/test-scratch/" + name;
}

std::string scratchDir(const std::string& name) {
  const std::string dir = scratchPath(name);
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  std::filesystem::create_directories(dir, ec);
  return dir;
}

bool fileExists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0;
}

bool requireSharedData(const std::string& folder) {
  const std::string dir = sharedDataDir() + "/" + folder;
  if (fileExists(dir)) return true;
  std::printf("\nSKIP: needs real data in %s (absent here)\n", dir.c_str());
  return false;
}

bool longTestsWanted(const char* what) {
  const char* enabled = std::getenv("AREOMAP_LONG_TESTS");
  if (enabled != nullptr && std::string(enabled) == "1") return true;
  std::printf("SKIP: %s run with AREOMAP_LONG_TESTS=1 (ctest -L long)\n", what);
  return false;
}

bool underEmulation(const char* what) {
  const char* emulator = std::getenv("AREOMAP_TEST_EMULATOR");
  if (emulator == nullptr || *emulator == '\0') return false;
  std::printf("emulated: %s\n", what);
  return true;
}

std::string toolPath(const std::string& tool) {
  const char* env = std::getenv("AREOMAP_BINARY_DIR");
  return (env != nullptr ? std::string(env) : std::string(AREOMAP_BINARY_DIR)) + "/bin/" + tool;
}

int runTool(const std::string& tool, const std::string& args) {
  const std::string command = toolPath(tool) + " " + args + " > /dev/null 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

std::vector<std::array<double, 6>> readEoSigmas(const std::string& eo_csv) {
  std::ifstream in(eo_csv);
  std::string line;
  std::getline(in, line);  // header
  std::vector<std::array<double, 6>> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::stringstream ss(line);
    std::string field;
    while (std::getline(ss, field, ',')) fields.push_back(field);
    if (fields.size() < 6) continue;
    std::array<double, 6> sigma{};
    for (int c = 0; c < 6; ++c) sigma[c] = std::atof(fields[fields.size() - 6 + c].c_str());
    rows.push_back(sigma);
  }
  return rows;
}

std::string makeTinyDataset(const std::string& name, int seed) {
  // Under CTest, the fixture tiny_dataset (tests/ground/CMakeLists.txt) renders seed 3 once for every group
  // that reads it, and names its folder in AREOMAP_TINY_DATASET (read only: the tests write elsewhere).
  const char* shared = std::getenv("AREOMAP_TINY_DATASET");
  if (seed == 3 && shared != nullptr && fileExists(std::string(shared) + "/panorama.json")) return shared;
  // Otherwise one folder per process: CTest runs a test executable's groups as separate, concurrent processes.
  const std::string dir = scratchDir(name + "-" + std::to_string(::getpid())) + "/sim";
  if (runTool("areomap-sim", "--preset tiny --seed " + std::to_string(seed) + " --out " + dir) != 0)
    return "";
  return dir;
}

}  // namespace areomap::test
