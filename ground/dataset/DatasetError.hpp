// The error of every dataset reader and writer: a cli::InputError (tools exit 1 with it) that names the
// file, the field (or line and column) and what was expected.
#pragma once

#include <string>

#include "ground/cli/Cli.hpp"

namespace areomap {

class DatasetError : public cli::InputError {
 public:
  // what() = "<file>: <field>: <message>" (the field part is left out when empty).
  DatasetError(const std::string& file, const std::string& field, const std::string& message)
      : cli::InputError(file, field, message), message_(message) {}

  const std::string& message() const { return message_; }

  // The same error of a lower layer (its message "<file>: <what>") as a DatasetError naming `file`.
  static DatasetError from(const std::string& file, const cli::InputError& e) {
    const std::string what = e.what();
    const std::string prefix = file + ": ";
    return DatasetError(file, "", what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what);
  }

 private:
  std::string message_;
};

}  // namespace areomap
