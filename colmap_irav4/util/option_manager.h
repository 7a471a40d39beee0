#pragma once

#include <functional>
#include <ostream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "colmap_irav4/util/enum_names.h"
#include "colmap_irav4/util/error.h"

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
  // A choice (util/enum_names.h): parsed and printed by its names; a value
  // not among them is refused naming the flag and the allowed names.
  template <typename Enum, typename = std::enable_if_t<std::is_enum_v<Enum>>>
  void Add(const std::string& name, Enum* value, const std::string& help) {
    AddOption(
        name, help, "choice", EnumName(*value), value,
        [value](const std::string& flag, const std::string& text) {
          if (!ParseEnum(text, value)) {
            throw InputError("--" + flag, "must be " + EnumNameList<Enum>() +
                                              ", got '" + text + "'");
          }
        },
        [value] { return EnumName(*value); });
  }
  // Another program's name for the registered flag `name` (COLMAP 4's, e.g.
  // --GlobalMapper.num_threads for --Mapper.num_threads): parses into the
  // same member, and errors about that member name the flag as typed.
  // Giving both names is an error. Not written by Write().
  void AddAlias(const std::string& alias, const std::string& name);
  // Another program's boolean flag whose behaviour ours has fixed: accepted
  // with `value`, any other value throws naming the flag and `note`.
  void AddFixed(const std::string& name, bool value, const std::string& note);
  // Another program's flag that ours does not support: given at all, it
  // throws naming the flag and `note`.
  void AddUnsupported(const std::string& name, const std::string& note);

  // argv[0] is the sub-command's name (or the program's); options follow.
  // Returns false if help was requested (and printed to stdout).
  bool Parse(int argc, char** argv);
  // Whether the option was given on the command line by the last Parse.
  bool IsSet(const std::string& name) const;

  // Runs `check` (the options structs' Check()); an OptionError about a
  // registered member (or about a registered flag, named by a check on a
  // registered copy) is rethrown naming that member's flag as typed.
  void Check(const std::function<void()>& check) const;

  // The registered flags (without "--") and their types (bool, int, double,
  // string, choice), in registration order; aliases, fixed and unsupported
  // flags excluded.
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
    // The name the value was given under (an alias's, or name).
    std::string set_as;
    // An alias: the index of the registered option it stands for.
    int target = -1;
    // A flag of another program: given, Parse throws `unsupported` (a fixed
    // flag: unless its value is `fixed_value`).
    bool foreign = false;
    std::string fixed_value;
    std::string unsupported;
    const void* address = nullptr;
    // Parses the text given under flag `flag` (errors name it).
    std::function<void(const std::string& flag, const std::string& text)>
        assign;
    std::function<std::string()> value;  // the current value as text
  };
  Option& AddOption(
      const std::string& name, const std::string& help, const std::string& type,
      std::string default_value, const void* address,
      std::function<void(const std::string&, const std::string&)> assign,
      std::function<std::string()> value);

  Option* Find(const std::string& name);
  const Option* Find(const std::string& name) const;
  // The flag an error about `option`'s member names: as the user typed it.
  static std::string FlagName(const Option& option);

  std::string command_name_;
  std::string description_;
  std::vector<Option> options_;
};

}  // namespace colmap_irav4
