// The error of every dataset reader and writer: names the file, the field (or line and column) and what
// was expected, so that a tool can print it and exit 1.
#pragma once

#include <stdexcept>
#include <string>

namespace areomap {

class DatasetError : public std::runtime_error {
 public:
  // what() = "<file>: <field>: <message>" (the field part is left out when empty).
  DatasetError(const std::string& file, const std::string& field, const std::string& message);

  const std::string& file() const { return file_; }
  const std::string& field() const { return field_; }
  const std::string& message() const { return message_; }

 private:
  std::string file_;
  std::string field_;
  std::string message_;
};

}  // namespace areomap
