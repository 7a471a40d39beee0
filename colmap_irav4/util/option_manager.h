#pragma once

#include <functional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

namespace colmap_irav4 {

// Parses "--name value" / "--name=value" command lines in COLMAP's style and
// writes the values straight into the options structs of the components:
//   OptionManager options("rotation_averager");
//   options.AddRequired("database_path", &database_path, "COLMAP database");
//   options.Add("RotationAveraging.theta_deg", &ra_options.theta_deg,
//               "outlier threshold (deg)");
//   if (!options.Parse(argc, argv)) return 0;  // -h / --help was printed
// Unknown options, missing values, malformed numbers and missing required
// options throw InputError naming the option. Every member is registered
// once (a second registration, by name or by address, is a programming
// error), and Check() runs the structs' Check() so that their errors name
// the flag under which the member was registered.
class OptionManager {
 public:
  explicit OptionManager(std::string command_name,
                         std::string description = "");

  void Add(const std::string& name, bool* value, const std::string& help);
  void Add(const std::string& name, int* value, const std::string& help);
  void Add(const std::string& name, double* value, const std::string& help);
  void Add(const std::string& name, std::string* value,
           const std::string& help);
  void AddRequired(const std::string& name, std::string* value,
                   const std::string& help);

  // argv[0] is the sub-command's name (or the program's); options follow.
  // Returns false if help was requested (and printed to stdout).
  bool Parse(int argc, char** argv);
  // Whether the option was given on the command line by the last Parse.
  bool IsSet(const std::string& name) const;

  // Runs `check` (the options structs' Check()); an OptionError about a
  // registered member is rethrown as an InputError naming that member's flag.
  void Check(const std::function<void()>& check) const;

  // The registered flags (without "--") and their types (bool, int, double,
  // string), in registration order.
  std::vector<std::pair<std::string, std::string>> Options() const;

  void PrintHelp(std::ostream& stream) const;
  // The options' current values in COLMAP's project.ini format: name=value
  // lines, those named Section.name under a [Section] line; doubles exact.
  void Write(std::ostream& stream) const;

 private:
  struct Option {
    std::string name;
    std::string help;
    std::string default_value;
    std::string type;
    bool required = false;
    bool set = false;
    const void* address = nullptr;
    std::function<void(const std::string&)> assign;
    std::function<std::string()> value;  // the current value as text
  };
  Option& AddOption(const std::string& name, const std::string& help,
                    const std::string& type, std::string default_value,
                    const void* address,
                    std::function<void(const std::string&)> assign,
                    std::function<std::string()> value);

  std::string command_name_;
  std::string description_;
  std::vector<Option> options_;
};

}  // namespace colmap_irav4
