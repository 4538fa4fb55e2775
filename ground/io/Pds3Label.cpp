#include "ground/io/Pds3Label.hpp"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "ground/cli/Cli.hpp"

namespace areomap::io {
namespace {

// A label is at most this many bytes; MER labels are ~40 kB with the VICAR header, MSL ~60 kB.
constexpr std::size_t kMaxLabelBytes = 1 << 20;

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

// Open parentheses/braces and quotes: a value continues on the next line while this is not balanced.
bool balanced(const std::string& v) {
  int depth = 0;
  bool quote = false;
  for (char c : v) {
    if (c == '"') quote = !quote;
    if (quote) continue;
    if (c == '(' || c == '{') ++depth;
    if (c == ')' || c == '}') --depth;
  }
  return depth <= 0 && !quote;
}

}  // namespace

Pds3Label Pds3Label::parse(const std::string& text, const std::string& file) {
  Pds3Label label;
  label.file_ = file;
  std::vector<std::string> scopes;
  std::istringstream in(text);
  std::string raw;
  bool in_comment = false;
  bool ended = false;
  std::string pending_key, pending_value;
  while (std::getline(in, raw)) {
    const std::string line = trim(stripComments(raw, in_comment));
    if (!pending_key.empty()) {
      pending_value += " " + line;
      if (!balanced(pending_value)) continue;
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
      if (scopes.empty()) throw cli::InputError(file, key, "closes a " + key.substr(4) + " that was not opened");
      scopes.pop_back();
      continue;
    }
    if (!balanced(value)) {
      pending_key = key;
      pending_value = value;
      continue;
    }
    label.statements_.push_back({scopes.empty() ? "" : scopes.back(), key, value});
  }
  if (!ended) {
    throw cli::InputError(file, "END", pending_key.empty() ? "the PDS3 label has no END (truncated file?)"
                                                           : "the value of " + pending_key + " is not closed");
  }
  return label;
}

Pds3Label Pds3Label::read(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw cli::InputError(path, "file", "cannot open");
  std::string text(kMaxLabelBytes, '\0');
  f.read(&text[0], static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<std::size_t>(f.gcount()));
  // The label is text: stop at the first NUL (the image data of an attached label may follow END).
  const std::size_t nul = text.find('\0');
  if (nul != std::string::npos) text.resize(nul);
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
  if (v.size() >= 2 && (v.front() == '"' || v.front() == '\'') && v.back() == v.front()) v = v.substr(1, v.size() - 2);
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
    throw cli::InputError(file_, scope.empty() || scope == "*" ? key : scope + "." + key, "expected an integer");
  }
  return static_cast<long>(x);
}

}  // namespace areomap::io
