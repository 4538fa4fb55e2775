#include "ground/cli/Cli.hpp"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "ground/cli/Parallel.hpp"

namespace areomap::cli {
namespace {
std::string g_tool_name = "areomap";

double parseNumber(const std::string& name, const std::string& text) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end == nullptr || *end != '\0') {
    throw UsageError(name + ": expected a number, got '" + text + "'");
  }
  return value;
}
}  // namespace

InputError::InputError(const std::string& file, const std::string& field, const std::string& what)
    : std::runtime_error(file + (field.empty() ? std::string() : ": " + field) + ": " + what),
      file_(file),
      field_(field) {}

Args::Args(int argc, char** argv) : program_(argc > 0 ? argv[0] : "") {
  for (int i = 1; i < argc; ++i) tokens_.emplace_back(argv[i]);
  used_.assign(tokens_.size(), false);
}

bool Args::flag(const std::string& name) {
  bool found = false;
  for (std::size_t i = 0; i < tokens_.size(); ++i) {
    if (!used_[i] && tokens_[i] == name) {
      used_[i] = true;
      found = true;
    }
  }
  return found;
}

std::optional<std::string> Args::option(const std::string& name) {
  std::vector<std::string> values = options(name);
  if (values.empty()) return std::nullopt;
  return values.back();
}

std::vector<std::string> Args::options(const std::string& name) {
  std::vector<std::string> values;
  for (std::size_t i = 0; i < tokens_.size(); ++i) {
    if (used_[i]) continue;
    if (tokens_[i] == name) {
      if (i + 1 >= tokens_.size() || used_[i + 1]) throw UsageError(name + " needs a value");
      used_[i] = used_[i + 1] = true;
      values.push_back(tokens_[++i]);
    } else if (tokens_[i].rfind(name + "=", 0) == 0) {
      used_[i] = true;
      values.push_back(tokens_[i].substr(name.size() + 1));
    }
  }
  return values;
}

std::string Args::option(const std::string& name, const std::string& fallback) {
  const auto v = option(name);
  return v ? *v : fallback;
}

std::string Args::required(const std::string& name) {
  const auto v = option(name);
  if (!v) throw UsageError("missing required option " + name);
  return *v;
}

double Args::number(const std::string& name, double fallback) {
  const auto v = option(name);
  return v ? parseNumber(name, *v) : fallback;
}

int64_t Args::integer(const std::string& name, int64_t fallback) {
  const auto v = option(name);
  if (!v) return fallback;
  char* end = nullptr;
  const long long value = std::strtoll(v->c_str(), &end, 10);
  if (v->empty() || end == nullptr || *end != '\0') {
    throw UsageError(name + ": expected an integer, got '" + *v + "'");
  }
  return value;
}

std::optional<std::vector<double>> Args::numbers(const std::string& name, std::size_t count) {
  std::optional<std::vector<double>> values;
  for (std::size_t i = 0; i < tokens_.size(); ++i) {
    if (used_[i] || tokens_[i] != name) continue;
    if (i + count >= tokens_.size()) throw UsageError(name + " needs " + std::to_string(count) + " values");
    std::vector<double> v;
    used_[i] = true;
    for (std::size_t k = 1; k <= count; ++k) {
      if (used_[i + k]) throw UsageError(name + " needs " + std::to_string(count) + " values");
      v.push_back(parseNumber(name, tokens_[i + k]));
      used_[i + k] = true;
    }
    values = v;
    i += count;
  }
  return values;
}

void Args::checkLeftovers() {
  if (positionals_checked_) return;
  positionals_checked_ = true;
  for (std::size_t i = 0; i < tokens_.size(); ++i) {
    if (!used_[i] && tokens_[i].size() > 1 && tokens_[i][0] == '-' &&
        !(tokens_[i][1] >= '0' && tokens_[i][1] <= '9') && tokens_[i][1] != '.') {
      throw UsageError("unknown option " + tokens_[i]);
    }
  }
}

std::optional<std::string> Args::optionalPositional(std::size_t index) {
  checkLeftovers();
  std::size_t n = 0;
  for (std::size_t i = 0; i < tokens_.size(); ++i) {
    if (used_[i]) continue;
    if (n == index) return tokens_[i];
    ++n;
  }
  return std::nullopt;
}

std::string Args::positional(std::size_t index, const std::string& what) {
  const auto v = optionalPositional(index);
  if (!v) throw UsageError("missing " + what);
  return *v;
}

std::size_t Args::positionalCount() {
  checkLeftovers();
  std::size_t n = 0;
  for (std::size_t i = 0; i < tokens_.size(); ++i) n += used_[i] ? 0 : 1;
  return n;
}

void Args::finish() {
  checkLeftovers();
  for (std::size_t i = 0; i < tokens_.size(); ++i) {
    if (!used_[i]) throw UsageError("unexpected argument '" + tokens_[i] + "'");
  }
}

int runTool(const char* name, int argc, char** argv, const char* usage, const std::function<int(Args&)>& body) {
  g_tool_name = name;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(usage, stdout);
      return 0;
    }
  }
  try {
    Args args(argc, argv);
    const int code = body(args);
    return code < 0 || code > 125 ? 1 : code;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "%s: %s\n(see %s --help)\n", name, e.what(), name);
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: %s\n", name, e.what());
    return 1;
  }
}

void warn(const std::string& text) { std::fprintf(stderr, "%s: warning: %s\n", g_tool_name.c_str(), text.c_str()); }
void info(const std::string& text) { std::fprintf(stderr, "%s: %s\n", g_tool_name.c_str(), text.c_str()); }

double nowSeconds() {
  using Clock = std::chrono::steady_clock;
  return std::chrono::duration<double>(Clock::now().time_since_epoch()).count();
}

Progress::Progress(const std::string& label, std::size_t total)
    : label_(label), total_(total), tty_(::isatty(STDERR_FILENO) != 0), start_s_(nowSeconds()) {
  print(false);
}

Progress::~Progress() {
  if (!finished_) done();
}

void Progress::step(std::size_t count) {
  current_ += count;
  if (current_ > total_) current_ = total_;
  print(false);
}

void Progress::done() {
  current_ = total_;
  print(true);
  finished_ = true;
}

void Progress::print(bool final) {
  const int decile = total_ == 0 ? 10 : static_cast<int>(10 * current_ / total_);
  const double elapsed = nowSeconds() - start_s_;
  if (tty_) {
    std::fprintf(stderr, "\r%s: %s %zu/%zu (%.1f s)%s", g_tool_name.c_str(), label_.c_str(), current_, total_,
                 elapsed, final ? "\n" : "");
  } else if (final || decile != last_decile_) {
    std::fprintf(stderr, "%s: %s %zu/%zu (%.1f s)\n", g_tool_name.c_str(), label_.c_str(), current_, total_,
                 elapsed);
  }
  last_decile_ = decile;
  std::fflush(stderr);
}

void releaseFreedMemory() {
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

int threadsOption(Args& args) {
  const int64_t n = args.integer("--threads", -1);
  if (n != -1 && (n < 1 || n > kMaxThreads))
    throw UsageError("--threads needs a whole number from 1 to " + std::to_string(kMaxThreads));
  setThreads(n == -1 ? 0 : static_cast<int>(n));
  return threadCount();
}

}  // namespace areomap::cli
