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

// An invalid option value, thrown by an options struct's Check(): `field` is
// the offending member, `name` its command-line flag (without "--") in the
// commands that register the struct under its usual prefix, or, for a member
// no command registers, its C++ name ("ClusterAlignmentOptions::theta_deg",
// printed as is). A command whose
// OptionManager registered the member under another flag (e.g. the view
// graph's min_num_inliers as --Mapper.min_num_matches) renames it in
// OptionManager::Check(), so that the message names the flag the user typed.
class OptionError : public InputError {
 public:
  OptionError(const void* field, const std::string& name,
              const std::string& problem)
      : InputError((name.find("::") == std::string::npos ? "--" : "") + name,
                   problem),
        field_(field),
        name_(name),
        problem_(problem) {}
  const void* field() const { return field_; }
  const std::string& name() const { return name_; }
  const std::string& problem() const { return problem_; }

 private:
  const void* field_;
  std::string name_;
  std::string problem_;
};

}  // namespace colmap_irav4
