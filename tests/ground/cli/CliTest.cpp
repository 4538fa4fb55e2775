#include <cstddef>
#include <string>
#include <vector>

#include "ground/cli/Cli.hpp"

#include <CppUTest/TestHarness.h>

using areomap::cli::Args;

namespace {
struct Argv {
  explicit Argv(std::vector<std::string> a) : strings(std::move(a)) {
    for (auto& s : strings) ptrs.push_back(s.data());
  }
  int argc() const { return static_cast<int>(ptrs.size()); }
  char** argv() { return ptrs.data(); }
  std::vector<std::string> strings;
  std::vector<char*> ptrs;
};
}  // namespace

TEST_GROUP(Cli){};

TEST(Cli, OptionsFlagsAndPositionals) {
  Argv a({"tool", "data", "--out", "dir", "--json", "--seed=7", "--size", "640", "480", "extra"});
  Args args(a.argc(), a.argv());
  CHECK_TRUE(args.flag("--json"));
  CHECK_FALSE(args.flag("--quiet"));
  STRCMP_EQUAL("dir", args.required("--out").c_str());
  LONGS_EQUAL(7, args.integer("--seed", 1));
  DOUBLES_EQUAL(2.5, args.number("--noise-px", 2.5), 0.0);
  const auto size = args.numbers("--size", 2);
  CHECK_TRUE(size.has_value());
  DOUBLES_EQUAL(480.0, (*size)[1], 0.0);
  LONGS_EQUAL(2, args.positionalCount());
  STRCMP_EQUAL("data", args.positional(0, "DATASET").c_str());
  STRCMP_EQUAL("extra", args.positional(1, "X").c_str());
}

TEST(Cli, UnknownOptionIsAUsageError) {
  Argv a({"tool", "data", "--bogus"});
  Args args(a.argc(), a.argv());
  CHECK_THROWS(areomap::cli::UsageError, args.positional(0, "DATASET"));
}

TEST(Cli, ExitCodesFollowTheContract) {
  Argv ok({"tool"});
  LONGS_EQUAL(0, areomap::cli::runTool("t", ok.argc(), ok.argv(), "usage\n", [](Args&) { return 0; }));
  Argv help({"tool", "--help"});
  LONGS_EQUAL(0, areomap::cli::runTool("t", help.argc(), help.argv(), "usage\n", [](Args&) { return 1; }));
  Argv bad({"tool", "--seed", "x"});
  LONGS_EQUAL(2, areomap::cli::runTool("t", bad.argc(), bad.argv(), "usage\n", [](Args& args) {
                return static_cast<int>(args.integer("--seed", 0));
              }));
  Argv missing({"tool"});
  LONGS_EQUAL(2, areomap::cli::runTool("t", missing.argc(), missing.argv(), "usage\n",
                                       [](Args& args) { return static_cast<int>(args.required("--out").size()); }));
  LONGS_EQUAL(1, areomap::cli::runTool("t", ok.argc(), ok.argv(), "usage\n", [](Args&) -> int {
                throw areomap::cli::InputError("panorama.json", "pairs[0].left.image", "missing");
              }));
  // A signal-like code is never returned by a tool body.
  LONGS_EQUAL(1, areomap::cli::runTool("t", ok.argc(), ok.argv(), "usage\n", [](Args&) { return 200; }));
}

TEST(Cli, InputErrorNamesFileAndField) {
  const areomap::cli::InputError e("models/p000_L.cahvor", "A", "|A| = 0.5, expected 1");
  STRCMP_EQUAL("models/p000_L.cahvor: A: |A| = 0.5, expected 1", e.what());
}

