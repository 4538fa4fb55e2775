#include "ground/io/Pds3Label.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "ground/cli/Cli.hpp"

namespace areomap::io {
namespace {

std::string trim(const std::string& s) {
  std::size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

std::string stripComments(const std::string& line, bool& in_comment) {
  std::string out;
  for (std::size_t i = 0; i < line.size(); ++i) {
    if (in_comment) {
      if (line.compare(i, 2, "*/") == 0) {
        in_comment = false;
        ++i;
      }
      continue;
    }
    if (line.compare(i, 2, "/*") == 0) {
      in_comment = true;
      ++i;
      continue;
    }
    out += line[i];
  }
  return out;
}

// Open parentheses/braces and quotes: a value continues on the next line while it is not balanced. The
// state is carried from line to line, so a value over n lines is scanned once, not n times (a long unclosed
// value would otherwise make the parse quadratic).
class Balance {
 public:
  void scan(const std::string& text, std::size_t& counted) {
    for (char c : text) {
      if (c == '"') quote_ = !quote_;
      if (quote_) continue;
      if (c == '(' || c == '{') ++depth_;
      if (c == ')' || c == '}') --depth_;
    }
    counted += text.size();
  }
  bool closed() const { return depth_ <= 0 && !quote_; }

 private:
  long depth_ = 0;
  bool quote_ = false;
};

}  // namespace

Pds3Label Pds3Label::parse(const std::string& text, const std::string& file, Pds3ParseWork* work) {
  Pds3ParseWork local;
  Pds3ParseWork& counted = work != nullptr ? *work : local;
  counted = Pds3ParseWork{};
  Pds3Label label;
  label.file_ = file;
  std::vector<std::string> scopes;
  std::istringstream in(text);
  std::string raw;
  bool in_comment = false;
  bool ended = false;
  std::string pending_key, pending_value;
  Balance pending_balance;
  while (std::getline(in, raw)) {
    const std::string line = trim(stripComments(raw, in_comment));
    if (!pending_key.empty()) {
      pending_value += ' ';
      pending_value += line;
      pending_balance.scan(line, counted.balance_chars);
      if (!pending_balance.closed()) continue;
      label.statements_.push_back({scopes.empty() ? "" : scopes.back(), pending_key, trim(pending_value)});
      pending_key.clear();
      continue;
    }
    if (line.empty()) continue;
    if (line == "END") {
      ended = true;
      break;
    }
    const std::size_t eq = line.find('=');
    if (eq == std::string::npos) continue;  // stray text: not a statement
    const std::string key = trim(line.substr(0, eq));
    const std::string value = trim(line.substr(eq + 1));
    if (key == "GROUP" || key == "OBJECT") {
      scopes.push_back(value);
      continue;
    }
    if (key == "END_GROUP" || key == "END_OBJECT") {
      if (scopes.empty())
        throw cli::InputError(file, key, "closes a " + key.substr(4) + " that was not opened");
      scopes.pop_back();
      continue;
    }
    Balance balance;
    balance.scan(value, counted.balance_chars);
    if (!balance.closed()) {
      pending_key = key;
      pending_value = value;
      pending_balance = balance;
      continue;
    }
    label.statements_.push_back({scopes.empty() ? "" : scopes.back(), key, value});
  }
  if (!ended) {
    throw cli::InputError(file, "END",
                          pending_key.empty() ? "the PDS3 label has no END (truncated file?)"
                                              : "the value of " + pending_key + " is not closed");
  }
  return label;
}

Pds3Label Pds3Label::read(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw cli::InputError(path, "file", "cannot open");
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);  // not a regular file: read to the end
  // In chunks of at most 64 KiB, up to the first NUL (the label is text; the image data of an attached
  // label may follow END): a 40 kB label of a 2 MB image reads one chunk, a fuzz input of 100 bytes
  // allocates 100 bytes (no 1 MiB buffer zeroed per file).
  const std::size_t have =
      ec ? kMaxBytes : static_cast<std::size_t>(std::min<std::uintmax_t>(size, kMaxBytes));
  constexpr std::size_t kChunk = std::size_t{1} << 16;
  std::string text;
  while (text.size() < have) {
    const std::size_t at = text.size();
    text.resize(at + std::min(kChunk, have - at));
    f.read(&text[at], static_cast<std::streamsize>(text.size() - at));
    const std::size_t got = static_cast<std::size_t>(f.gcount());
    text.resize(at + got);
    const std::size_t nul = text.find('\0', at);
    if (nul != std::string::npos) {
      text.resize(nul);
      break;
    }
    if (got == 0) break;
  }
  return parse(text, path);
}

const std::string* Pds3Label::find(const std::string& key, const std::string& scope) const {
  for (const Pds3Statement& s : statements_) {
    if (s.key == key && (scope == "*" || s.scope == scope)) return &s.value;
  }
  return nullptr;
}

bool Pds3Label::hasScope(const std::string& scope) const {
  for (const Pds3Statement& s : statements_) {
    if (s.scope == scope) return true;
  }
  return false;
}

std::string Pds3Label::unquote(const std::string& value) {
  std::string v = trim(value);
  const std::size_t unit = v.find('<');
  if (unit != std::string::npos && v.find('(') == std::string::npos) v = trim(v.substr(0, unit));
  if (v.size() >= 2 && (v.front() == '"' || v.front() == '\'') && v.back() == v.front())
    v = v.substr(1, v.size() - 2);
  return v;
}

std::vector<std::string> Pds3Label::tuple(const std::string& value) {
  std::string v = trim(value);
  if (v.size() >= 2 && (v.front() == '(' || v.front() == '{')) v = v.substr(1, v.size() - 2);
  std::vector<std::string> items;
  std::string item;
  std::istringstream in(v);
  while (std::getline(in, item, ',')) items.push_back(unquote(item));
  return items;
}

std::string Pds3Label::required(const std::string& key, const std::string& scope) const {
  const std::string* v = find(key, scope);
  if (v == nullptr) {
    throw cli::InputError(file_, scope.empty() || scope == "*" ? key : scope + "." + key, "missing");
  }
  return *v;
}

double Pds3Label::number(const std::string& key, const std::string& scope) const {
  const std::string v = unquote(required(key, scope));
  char* end = nullptr;
  const double x = std::strtod(v.c_str(), &end);
  if (end == v.c_str() || !std::isfinite(x)) {
    throw cli::InputError(file_, scope.empty() || scope == "*" ? key : scope + "." + key,
                          "expected a number, found '" + v + "'");
  }
  return x;
}

long Pds3Label::integer(const std::string& key, const std::string& scope) const {
  const double x = number(key, scope);
  if (x != std::floor(x) || std::fabs(x) > 1e12) {
    throw cli::InputError(file_, scope.empty() || scope == "*" ? key : scope + "." + key,
                          "expected an integer");
  }
  return static_cast<long>(x);
}

}  // namespace areomap::io
