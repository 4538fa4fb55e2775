// A PDS3 label (attached to a .IMG or a detached .LBL): "KEY = VALUE" statements with GROUP/OBJECT
// nesting, values that continue over lines inside parentheses or quotes, /* comments */, ending at END.
#pragma once

#include <string>
#include <vector>

namespace areomap::io {

struct Pds3Statement {
  std::string scope;  // innermost GROUP or OBJECT name ("" at the top level), e.g. GEOMETRIC_CAMERA_MODEL
  std::string key;    // e.g. MODEL_COMPONENT_1, ^IMAGE
  std::string value;  // raw text without comments, whitespace collapsed
};

class Pds3Label {
 public:
  // Parses the label at the start of `text`; throws cli::InputError(file, "label", ...) if no END is found
  // or a statement is malformed.
  static Pds3Label parse(const std::string& text, const std::string& file);
  // Reads the label of a file (the first bytes up to END).
  static Pds3Label read(const std::string& path);

  // Value of `key` in `scope` ("" = top level, "*" = any scope); nullptr when absent.
  const std::string* find(const std::string& key, const std::string& scope = "*") const;
  bool hasScope(const std::string& scope) const;
  const std::string& file() const { return file_; }
  const std::vector<Pds3Statement>& statements() const { return statements_; }

  // Helpers: a value with quotes and a trailing unit (<BYTES>) removed; the items of a "(a, b, c)" tuple.
  static std::string unquote(const std::string& value);
  static std::vector<std::string> tuple(const std::string& value);

  // Required values; throw cli::InputError naming the file and "SCOPE.KEY".
  std::string required(const std::string& key, const std::string& scope) const;
  double number(const std::string& key, const std::string& scope) const;
  long integer(const std::string& key, const std::string& scope) const;

 private:
  std::string file_;
  std::vector<Pds3Statement> statements_;
};

}  // namespace areomap::io
