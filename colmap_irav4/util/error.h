#pragma once

#include <stdexcept>
#include <string>

namespace colmap_irav4 {

// Recoverable error caused by the user's input (a file, an option). Caught at
// the command-line boundary, printed as one line, exit code 1. Messages name
// the file (or option) first: "<path>: <problem>".
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message)
      : std::runtime_error(message) {}
  InputError(const std::string& path, const std::string& problem)
      : std::runtime_error(path + ": " + problem) {}
};

}  // namespace colmap_irav4
