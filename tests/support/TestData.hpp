// Where tests find real data: ../shared/data beside the checkout (CI has it there), or $AREOMAP_SHARED_DATA.
// A test that needs it calls requireSharedData("folder"), which prints a SKIP line with the reason and
// returns false when it is absent; the test then returns early.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace areomap::test {

std::string sourceDir();                          // the repository root
std::string sharedDataDir();                      // ../shared/data (or $AREOMAP_SHARED_DATA)
std::string scratchDir(const std::string& name);  // an empty folder under the build tree for this test
std::string scratchPath(const std::string& name);  // scratchDir(name)'s path, the folder left as it is
bool requireSharedData(const std::string& folder);
// Whether AREOMAP_LONG_TESTS=1 asks for the long groups; otherwise prints "SKIP: <what> run with ..." and the
// group passes without running.
bool longTestsWanted(const char* what);
// Whether this test runs under a cross build's emulator (AREOMAP_TEST_EMULATOR, set by CTest): a solver test
// whose arithmetic is shown on the target by one case of a family runs that one there, and the whole family
// natively; it prints "emulated: <what>".
bool underEmulation(const char* what);
bool fileExists(const std::string& path);

// build/bin/<tool> ($AREOMAP_BINARY_DIR, else the build tree this test was configured in).
std::string toolPath(const std::string& tool);
// Runs build/bin/<tool> with `args` (a shell word list), output discarded; returns its exit code, 128 when
// it did not exit normally.
int runTool(const std::string& tool, const std::string& args);
// The six sigma columns of every row of an eo.csv (sigma_x_m .. sigma_rot_z_rad, its last six columns).
std::vector<std::array<double, 6>> readEoSigmas(const std::string& eo_csv);
// The `tiny` simulated panorama (areomap-sim --preset tiny --seed N) in scratchDir(name-PID)/sim, or seed 3
// as CTest's fixture tiny_dataset made it (AREOMAP_TINY_DATASET, areomap_tiny_dataset_groups); "" when the
// simulator failed. Tests keep the result in a function-local static to make it once per process, and do not
// write into it.
std::string makeTinyDataset(const std::string& name, int seed = 3);

}  // namespace areomap::test
