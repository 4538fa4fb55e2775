// Where tests find real data: ../shared/data beside the checkout (CI has it there), or $AREOMAP_SHARED_DATA.
// A test that needs it calls requireSharedData("folder"), which prints a SKIP line with the reason and
// returns false when it is absent; the test then returns early.
#pragma once

#include <string>

namespace areomap::test {

std::string sourceDir();         // the repository root
std::string sharedDataDir();     // ../shared/data (or $AREOMAP_SHARED_DATA)
std::string scratchDir(const std::string& name);  // an empty folder under the build tree for this test
bool requireSharedData(const std::string& folder);
bool fileExists(const std::string& path);

}  // namespace areomap::test
