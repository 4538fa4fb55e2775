// The house rules that a reader can check by counting (STYLE.md, the working agreement), over a source tree
// (CTest: house, house_self_test):
//
//   areomap-check-house ROOT             exit 0 when the tree keeps every rule, else 1 with one line per
//                                        break: "file:line: what"
//   areomap-check-house --self-test DIR  plants a tree with known breaks (and near misses) in DIR and checks
//                                        that exactly those breaks are found
//
// The rules, over every .cpp, .hpp and .h under firmware_core/, ground/, msgs/, platform/, tests/ and
// toolchains/:
//   - a file has at most kMaxFileLines lines;
//   - a function body (from its opening brace to its closing one) has at most kMaxFunctionLines lines,
//     unless the comment right above the function says why, with the marker kLongMarker;
//   - a comment names no issue number (the word issue followed by a number, a '#' before one to five
//     digits, or an 'i' and a number in parentheses): a comment states the contract or the reason itself;
// and README.md has at most kMaxReadmeLines lines, BENCHMARKS.md at most kMaxBenchmarksLines.
//
// Functions are found by a heuristic, not a parser: comments, string and character literals are blanked,
// then a brace at file or namespace scope opens a function when the text since the previous ';', '{' or
// '}' holds a ')' and does not start a namespace, class, struct, union or enum. Functions defined inside a
// class body are not measured.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

constexpr int kMaxFileLines = 600;
constexpr int kMaxFunctionLines = 150;
constexpr int kMaxReadmeLines = 250;
constexpr int kMaxBenchmarksLines = 400;
const char* const kLongMarker = "Long because:";
const char* const kSourceFolders[] = {"firmware_core", "ground", "msgs", "platform", "tests", "toolchains"};

struct Break {
  std::string file;
  int line = 0;
  std::string what;
};

std::vector<std::string> readLines(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<std::string> lines;
  std::string line;
  while (std::getline(in, line)) lines.push_back(line);
  return lines;
}

// The text with every comment, string and character literal replaced by spaces (newlines kept), and each
// comment's text with its line, for the issue-number rule.
struct Stripped {
  std::string code;
  std::vector<std::pair<int, std::string>> comments;
};

Stripped strip(const std::string& text) {
  Stripped out;
  out.code = text;
  int line = 1;
  std::size_t i = 0;
  const std::size_t n = text.size();
  auto blank = [&](std::size_t from, std::size_t to) {
    for (std::size_t k = from; k < to && k < n; ++k) {
      if (text[k] != '\n') out.code[k] = ' ';
    }
  };
  auto linesIn = [&](std::size_t from, std::size_t to) {
    return static_cast<int>(
        std::count(text.begin() + static_cast<long>(from), text.begin() + static_cast<long>(to), '\n'));
  };
  while (i < n) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      ++i;
    } else if (c == '/' && i + 1 < n && text[i + 1] == '/') {
      std::size_t end = text.find('\n', i);
      if (end == std::string::npos) end = n;
      out.comments.push_back({line, text.substr(i, end - i)});
      blank(i, end);
      i = end;
    } else if (c == '/' && i + 1 < n && text[i + 1] == '*') {
      std::size_t end = text.find("*/", i + 2);
      end = end == std::string::npos ? n : end + 2;
      out.comments.push_back({line, text.substr(i, end - i)});
      blank(i, end);
      line += linesIn(i, end);
      i = end;
    } else if (c == 'R' && i + 1 < n && text[i + 1] == '"' &&
               (i == 0 || !std::isalnum(static_cast<unsigned char>(text[i - 1])))) {
      // Raw string R"delim( ... )delim".
      const std::size_t open = text.find('(', i + 2);
      if (open == std::string::npos) break;
      const std::string close = ")" + text.substr(i + 2, open - i - 2) + "\"";
      std::size_t end = text.find(close, open);
      end = end == std::string::npos ? n : end + close.size();
      blank(i, end);
      line += linesIn(i, end);
      i = end;
    } else if (c == '"' ||
               (c == '\'' && !(i > 0 && std::isxdigit(static_cast<unsigned char>(text[i - 1]))))) {
      // A literal up to its unescaped closing quote (a ' between digits is a digit separator).
      std::size_t k = i + 1;
      while (k < n && text[k] != c && text[k] != '\n') k += text[k] == '\\' ? 2 : 1;
      const std::size_t end = std::min(n, k + 1);
      blank(i, end);
      i = end;
    } else {
      ++i;
    }
  }
  return out;
}

bool startsWithWord(const std::string& text, const std::string& word) {
  if (text.compare(0, word.size(), word) != 0) return false;
  return text.size() == word.size() ||
         !(std::isalnum(static_cast<unsigned char>(text[word.size()])) || text[word.size()] == '_');
}

// What a '{' opens, from the text since the previous ';', '{' or '}' (comments and literals blanked).
enum class Scope { kNamespace, kFunction, kOther };

Scope scopeOf(std::string header) {
  header = std::regex_replace(header, std::regex("(^|\\n)[ \\t]*#[^\\n]*"), "");  // preprocessor lines
  header = std::regex_replace(header, std::regex("^\\s+|\\s+$"), "");
  header = std::regex_replace(header, std::regex("^template\\s*<[^{;]*?>\\s*"), "");
  if (startsWithWord(header, "namespace") || startsWithWord(header, "extern")) return Scope::kNamespace;
  for (const char* kind : {"class", "struct", "union", "enum"}) {
    if (startsWithWord(header, kind)) return Scope::kOther;
  }
  return header.find(')') != std::string::npos ? Scope::kFunction : Scope::kOther;
}

// The line (1-based) of the first non-space character at or after `from`.
int lineAt(const std::string& code, std::size_t pos) {
  return 1 + static_cast<int>(std::count(code.begin(), code.begin() + static_cast<long>(pos), '\n'));
}

void checkFunctions(const std::string& name, const std::vector<std::string>& lines, const Stripped& s,
                    std::vector<Break>& breaks) {
  const std::string& code = s.code;
  std::vector<Scope> stack;
  std::vector<std::size_t> open_at;
  std::vector<std::size_t> header_at;
  std::size_t header_start = 0;
  for (std::size_t i = 0; i < code.size(); ++i) {
    const char c = code[i];
    if (c == ';') {
      header_start = i + 1;
    } else if (c == '{') {
      const bool outer =
          std::all_of(stack.begin(), stack.end(), [](Scope k) { return k == Scope::kNamespace; });
      Scope kind = Scope::kOther;
      if (outer) kind = scopeOf(code.substr(header_start, i - header_start));
      stack.push_back(kind);
      open_at.push_back(i);
      std::size_t first = header_start;
      while (first < i && std::isspace(static_cast<unsigned char>(code[first]))) ++first;
      header_at.push_back(first);
      header_start = i + 1;
    } else if (c == '}') {
      if (stack.empty()) continue;
      const Scope kind = stack.back();
      const std::size_t open = open_at.back();
      const std::size_t head = header_at.back();
      stack.pop_back();
      open_at.pop_back();
      header_at.pop_back();
      header_start = i + 1;
      if (kind != Scope::kFunction) continue;
      const int first_line = lineAt(code, open);
      const int body = lineAt(code, i) - first_line + 1;
      if (body <= kMaxFunctionLines) continue;
      // The comment right above the function (its header's first line), read upwards.
      bool explained = false;
      for (int l = lineAt(code, head) - 2; l >= 0; --l) {
        const std::string& text = lines[static_cast<std::size_t>(l)];
        const std::size_t at = text.find_first_not_of(" \t");
        if (at == std::string::npos || text.compare(at, 2, "//") != 0) break;
        explained = explained || text.find(kLongMarker) != std::string::npos;
      }
      if (!explained) {
        breaks.push_back({name, lineAt(code, head),
                          "function body of " + std::to_string(body) + " lines (at most " +
                              std::to_string(kMaxFunctionLines) + ", or a comment above it '" + kLongMarker +
                              " ...')"});
      }
    }
  }
}

void checkComments(const std::string& name, const Stripped& s, std::vector<Break>& breaks) {
  static const std::regex issue("\\bissues?\\s*#?\\s*[0-9]+|#[0-9]{1,5}\\b|\\(i[0-9]+\\)", std::regex::icase);
  for (const auto& [line, text] : s.comments) {
    std::istringstream lines(text);
    std::string part;
    int l = line;
    for (; std::getline(lines, part); ++l) {
      std::smatch m;
      if (std::regex_search(part, m, issue)) {
        breaks.push_back(
            {name, l, "an issue number in a comment ('" + m.str() + "'): state the reason instead"});
      }
    }
  }
}

void checkLength(const std::string& name, std::size_t count, int limit, std::vector<Break>& breaks) {
  if (static_cast<int>(count) > limit) {
    breaks.push_back(
        {name, limit + 1, std::to_string(count) + " lines (at most " + std::to_string(limit) + ")"});
  }
}

std::vector<Break> checkTree(const fs::path& root) {
  std::vector<Break> breaks;
  std::vector<fs::path> files;
  for (const char* folder : kSourceFolders) {
    if (!fs::is_directory(root / folder)) continue;
    for (const auto& entry : fs::recursive_directory_iterator(root / folder)) {
      const std::string ext = entry.path().extension().string();
      if (entry.is_regular_file() && (ext == ".cpp" || ext == ".hpp" || ext == ".h"))
        files.push_back(entry.path());
    }
  }
  std::sort(files.begin(), files.end());
  for (const fs::path& path : files) {
    const std::string name = fs::relative(path, root).generic_string();
    const std::vector<std::string> lines = readLines(path);
    checkLength(name, lines.size(), kMaxFileLines, breaks);
    std::ifstream in(path, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    const Stripped s = strip(text.str());
    checkFunctions(name, lines, s, breaks);
    checkComments(name, s, breaks);
  }
  for (const auto& [doc, limit] : {std::pair<const char*, int>{"README.md", kMaxReadmeLines},
                                   std::pair<const char*, int>{"BENCHMARKS.md", kMaxBenchmarksLines}}) {
    if (fs::exists(root / doc)) checkLength(doc, readLines(root / doc).size(), limit, breaks);
  }
  return breaks;
}

void write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

std::string repeat(const std::string& line, int times) {
  std::string out;
  for (int k = 0; k < times; ++k) out += line;
  return out;
}

// Plants a tree with one break of each rule (and near misses that keep the rules) and checks that exactly
// the planted breaks are found, by file and line.
int selfTest(const fs::path& dir) {
  fs::remove_all(dir);
  const std::string body = repeat("  x += 1;\n", kMaxFunctionLines);  // + the braces' lines: one too long
  const std::string fits = repeat("  x += 1;\n", kMaxFunctionLines - 2);
  // Breaks.
  write(dir / "firmware_core/a/Big.hpp", repeat("// x\n", kMaxFileLines + 1));
  write(dir / "ground/b/Long.cpp",
        "#include <x>\nnamespace n {\n\nint f(int x) {\n" + body + "  return x;\n}\n}\n");
  write(dir / "msgs/c/Issue.hpp",
        "// The rule of issue 33.\nint a;\n/* see #12 */\nint b;  // (i7)\nint c;  // #0000111111 bits\n");
  write(dir / "README.md", repeat("x\n", kMaxReadmeLines + 1));
  write(dir / "BENCHMARKS.md", repeat("x\n", kMaxBenchmarksLines + 1));
  // Near misses.
  write(dir / "platform/d/Fits.hpp", repeat("// x\n", kMaxFileLines));
  write(dir / "tests/e/Kept.cpp",
        "namespace {\n// Long because: one table, read top to bottom.\nint g(int x) {\n" + body +
            "  return x;\n}\n"
            "int h(int x) {\n" +
            fits +
            "}\n"
            "struct S {\n  int m(int x) {\n" +
            body +
            "  }\n};\n}  // namespace\n"
            "const char* s = \"issue 4 #5\";\n#include \"x.hpp\"  // the tissue 9 of x\n");
  write(dir / "toolchains/f/Other.txt", repeat("x\n", kMaxFileLines + 1));
  const std::set<std::string> expected = {
      "firmware_core/a/Big.hpp:601", "ground/b/Long.cpp:4", "msgs/c/Issue.hpp:1", "msgs/c/Issue.hpp:3",
      "msgs/c/Issue.hpp:4",          "README.md:251",       "BENCHMARKS.md:401"};
  std::set<std::string> found;
  for (const Break& b : checkTree(dir)) {
    found.insert(b.file + ":" + std::to_string(b.line));
    std::printf("found: %s:%d: %s\n", b.file.c_str(), b.line, b.what.c_str());
  }
  int failures = 0;
  for (const std::string& e : expected) {
    if (found.count(e) == 0) {
      std::printf("self test: the planted break %s was not found\n", e.c_str());
      ++failures;
    }
  }
  for (const std::string& f : found) {
    if (expected.count(f) == 0) {
      std::printf("self test: %s was reported but keeps the rules\n", f.c_str());
      ++failures;
    }
  }
  std::printf("house self test: %s\n", failures == 0 ? "ok" : "FAILED");
  return failures == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && std::string(argv[1]) == "--self-test") return selfTest(argv[2]);
  if (argc != 2) {
    std::fprintf(stderr, "usage: areomap-check-house ROOT | --self-test DIR\n");
    return 2;
  }
  const fs::path root = argv[1];
  if (!fs::is_directory(root)) {
    std::fprintf(stderr, "areomap-check-house: %s is not a folder\n", argv[1]);
    return 2;
  }
  const std::vector<Break> breaks = checkTree(root);
  for (const Break& b : breaks) std::printf("%s:%d: %s\n", b.file.c_str(), b.line, b.what.c_str());
  std::printf("house: %zu break(s)\n", breaks.size());
  return breaks.empty() ? 0 : 1;
}
