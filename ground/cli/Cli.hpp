// The shared front end of every areomap-* tool: argument parsing, the exit-code contract and progress.
//
// Exit codes (DESIGN.md "The contract in detail"): 0 success, 2 usage error, 1 any other error; errors go
// to stderr and name the file and the field. A tool's main is
//
//   int main(int argc, char** argv) {
//     return areomap::cli::runTool("areomap-xxx", argc, argv, kUsage, [](areomap::cli::Args& args) {
//       const std::string out = args.required("--out");
//       const std::string dataset = args.positional(0, "DATASET");
//       ...
//       return 0;
//     });
//   }
//
// Query options and flags first, then positionals: an unconsumed `--option` at that point is a usage error.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace areomap::cli {

// Bad command line: runTool prints it with "see --help" and exits 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Bad input data: names the file and the field ("panorama.json: pairs[3].left.image: no such file").
class InputError : public std::runtime_error {
 public:
  InputError(const std::string& file, const std::string& field, const std::string& what);
  const std::string& file() const { return file_; }
  const std::string& field() const { return field_; }

 private:
  std::string file_;
  std::string field_;
};

class Args {
 public:
  Args(int argc, char** argv);

  // `--name` present? Consumes it.
  bool flag(const std::string& name);
  // `--name VALUE` or `--name=VALUE`; consumes both. The last occurrence wins.
  std::optional<std::string> option(const std::string& name);
  std::string option(const std::string& name, const std::string& fallback);
  // Every `--name VALUE` / `--name=VALUE`, in order (a repeatable option); consumes them. VALUE may itself
  // start with "--" (a command line passed on).
  std::vector<std::string> options(const std::string& name);
  std::string required(const std::string& name);  // UsageError when absent
  double number(const std::string& name, double fallback);
  int64_t integer(const std::string& name, int64_t fallback);
  // `--name V1 V2 ... Vn` (n values, e.g. --size W H); nullopt when absent.
  std::optional<std::vector<double>> numbers(const std::string& name, std::size_t count);

  // Positionals: what is left after the options. The first call checks that no `--option` is left over.
  std::string positional(std::size_t index, const std::string& what);
  std::optional<std::string> optionalPositional(std::size_t index);
  std::size_t positionalCount();
  // Fails on anything not consumed (call at the end when the tool takes no positionals).
  void finish();

  const std::string& program() const { return program_; }

 private:
  void checkLeftovers();
  std::string program_;
  std::vector<std::string> tokens_;
  std::vector<bool> used_;
  bool positionals_checked_ = false;
};

// Runs a tool body with the exit-code contract: `--help`/`-h` prints `usage` to stdout and exits 0;
// UsageError -> 2; InputError and any other exception -> 1, the message on stderr prefixed by the tool name.
int runTool(const char* name, int argc, char** argv, const char* usage, const std::function<int(Args&)>& body);

// `--threads N` (consumed): the process-wide thread count of the ground's parallel work (Parallel.hpp),
// N >= 1; absent: every core. Set before any work; returns the count that will be used.
int threadsOption(Args& args);

// Hands the heaps' free memory back to the kernel (glibc's malloc_trim over every arena; nothing
// elsewhere): after a stage whose threads freed large buffers, before one that allocates on other threads,
// and by a node between panoramas, so that what stays resident is what the process holds.
void releaseFreedMemory();

// "name: warning: text" on stderr.
void warn(const std::string& text);
// "name: text" on stderr (progress and information that is not the tool's output).
void info(const std::string& text);

// Progress of a long job on stderr: a rewritten line on a terminal, a line per ~10 % otherwise.
class Progress {
 public:
  Progress(const std::string& label, std::size_t total);
  ~Progress();
  void step(std::size_t count = 1);
  void done();

 private:
  void print(bool final);
  std::string label_;
  std::size_t total_;
  std::size_t current_ = 0;
  int last_decile_ = -1;
  bool tty_;
  bool finished_ = false;
  double start_s_;
};

// Seconds since an arbitrary epoch (steady clock), for stage timings.
double nowSeconds();

}  // namespace areomap::cli
