// A PDS3 label (attached to a .IMG or a detached .LBL): "KEY = VALUE" statements with GROUP/OBJECT
// nesting, values that continue over lines inside parentheses or quotes, /* comments */, ending at END.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace areomap::io {

struct Pds3Statement {
  std::string scope;  // innermost GROUP or OBJECT name ("" at the top level), e.g. GEOMETRIC_CAMERA_MODEL
  std::string key;    // e.g. MODEL_COMPONENT_1, ^IMAGE
  std::string value;  // raw text without comments, whitespace collapsed
};

// The work of one Pds3Label::parse, for tests that bound it: the characters the bracket/quote balance check
// looked at. Each character of a value is looked at once (values continued over many lines are scanned
// incrementally), so this is at most the text's size: the parse is linear in the input.
struct Pds3ParseWork {
  std::size_t balance_chars = 0;
};

class Pds3Label {
 public:
  // A label is at most this many bytes (read() stops there); MER labels are ~40 kB with the VICAR header,
  // MSL ~60 kB.
  static constexpr std::size_t kMaxBytes = std::size_t{1} << 20;

  // Parses the label at the start of `text`; throws cli::InputError(file, "label", ...) if no END is found
  // or a statement is malformed. `work` (optional) receives the work done, also when it throws.
  static Pds3Label parse(const std::string& text, const std::string& file, Pds3ParseWork* work = nullptr);
  // Reads the label of a file: its text up to the first NUL (the image data of an attached label may follow
  // END), at most kMaxBytes; only the bytes read are allocated.
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
