#include "colmap_irav4/util/option_manager.h"

#include <algorithm>
#include <iostream>
#include <sstream>

#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

std::string FormatDouble(double value) {
  std::ostringstream stream;
  stream << value;
  return stream.str();
}

// The shortest text that reads back as exactly `value`.
std::string FormatDoubleExactly(double value) {
  for (int precision = 6; precision < 17; ++precision) {
    std::ostringstream stream;
    stream.precision(precision);
    stream << value;
    if (std::stod(stream.str()) == value) return stream.str();
  }
  std::ostringstream stream;
  stream.precision(17);
  stream << value;
  return stream.str();
}

bool ParseBool(const std::string& text, bool* value) {
  if (text == "1" || text == "true" || text == "True" || text == "TRUE") {
    *value = true;
    return true;
  }
  if (text == "0" || text == "false" || text == "False" || text == "FALSE") {
    *value = false;
    return true;
  }
  return false;
}

}  // namespace

OptionManager::OptionManager(std::string command_name, std::string description)
    : command_name_(std::move(command_name)),
      description_(std::move(description)) {}

OptionManager::Option& OptionManager::AddOption(
    const std::string& name, const std::string& help, const std::string& type,
    std::string default_value, const void* address,
    std::function<void(const std::string&, const std::string&)> assign,
    std::function<std::string()> value) {
  for (const Option& option : options_) {
    if (option.name == name) {
      throw std::logic_error("option --" + name + " registered twice");
    }
    if (address != nullptr && option.address == address) {
      throw std::logic_error("option --" + name + " is --" + option.name +
                             " registered a second time");
    }
  }
  Option option;
  option.name = name;
  option.help = help;
  option.type = type;
  option.default_value = std::move(default_value);
  option.address = address;
  option.assign = std::move(assign);
  option.value = std::move(value);
  options_.push_back(std::move(option));
  return options_.back();
}

void OptionManager::Add(const std::string& name, bool* value,
                        const std::string& help) {
  AddOption(
      name, help, "bool", *value ? "1" : "0", value,
      [value](const std::string& flag, const std::string& text) {
        if (!ParseBool(text, value)) {
          throw InputError("--" + flag,
                           "expected 0/1/true/false, got '" + text + "'");
        }
      },
      [value] { return std::string(*value ? "1" : "0"); });
}

void OptionManager::Add(const std::string& name, int* value,
                        const std::string& help) {
  AddOption(
      name, help, "int", std::to_string(*value), value,
      [value](const std::string& flag, const std::string& text) {
        size_t end = 0;
        try {
          const long parsed = std::stol(text, &end);
          if (end == text.size() && parsed >= INT32_MIN &&
              parsed <= INT32_MAX) {
            *value = static_cast<int>(parsed);
            return;
          }
        } catch (const std::exception&) {
        }
        throw InputError("--" + flag,
                         "expected an integer, got '" + text + "'");
      },
      [value] { return std::to_string(*value); });
}

void OptionManager::Add(const std::string& name, double* value,
                        const std::string& help) {
  AddOption(
      name, help, "double", FormatDouble(*value), value,
      [value](const std::string& flag, const std::string& text) {
        size_t end = 0;
        try {
          const double parsed = std::stod(text, &end);
          if (end == text.size()) {
            *value = parsed;
            return;
          }
        } catch (const std::exception&) {
        }
        throw InputError("--" + flag, "expected a number, got '" + text + "'");
      },
      [value] { return FormatDoubleExactly(*value); });
}

void OptionManager::Add(const std::string& name, std::string* value,
                        const std::string& help) {
  AddOption(
      name, help, "string", *value, value,
      [value](const std::string&, const std::string& text) { *value = text; },
      [value] { return *value; });
}

void OptionManager::AddRequired(const std::string& name, std::string* value,
                                const std::string& help) {
  AddOption(
      name, help, "string", *value, value,
      [value](const std::string&, const std::string& text) { *value = text; },
      [value] { return *value; })
      .required = true;
}

bool OptionManager::Parse(int argc, char** argv) {
  for (Option& option : options_) {
    option.set = false;
    option.set_as.clear();
  }
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "-h" || arg == "--help" || arg == "help") {
      PrintHelp(std::cout);
      return false;
    }
    if (arg.rfind("--", 0) != 0) {
      throw InputError(command_name_, "unexpected argument '" + arg +
                                          "' (options are --name value)");
    }
    std::string name = arg.substr(2);
    std::string value;
    bool has_value = false;
    const size_t equals = name.find('=');
    if (equals != std::string::npos) {
      value = name.substr(equals + 1);
      name = name.substr(0, equals);
      has_value = true;
    }
    Option* match = Find(name);
    if (match == nullptr) {
      throw InputError("--" + name, "unknown option for '" + command_name_ +
                                        "' (see " + command_name_ + " -h)");
    }
    if (match->foreign && match->fixed_value.empty()) {
      throw InputError("--" + name, match->unsupported);
    }
    Option& dest = match->target >= 0 ? options_[match->target] : *match;
    if (!has_value) {
      const bool next_is_option =
          i + 1 >= argc || std::string(argv[i + 1]).rfind("--", 0) == 0;
      if (next_is_option) {
        // A bare boolean flag means true.
        if (dest.type != "bool") {
          throw InputError("--" + name, "missing value");
        }
        value = "1";
      } else {
        value = argv[++i];
      }
    }
    if (match->foreign) {
      bool fixed = false;
      if (!ParseBool(value, &fixed) ||
          (fixed ? "1" : "0") != match->fixed_value) {
        throw InputError("--" + name, match->unsupported);
      }
      continue;
    }
    if (dest.set && dest.set_as != name) {
      throw InputError("--" + name, "sets the same option as --" + dest.set_as +
                                        "; give one of them");
    }
    dest.assign(name, value);
    dest.set = true;
    dest.set_as = name;
  }
  for (const Option& option : options_) {
    if (option.required && !option.set) {
      throw InputError("--" + option.name,
                       "required option of '" + command_name_ + "' missing");
    }
    // A required path given as '' (an unset shell variable) names nothing.
    if (option.required && option.type == "string" &&
        static_cast<const std::string*>(option.address)->empty()) {
      throw InputError("--" + option.name, "is empty");
    }
  }
  return true;
}

void OptionManager::Check(const std::function<void()>& check) const {
  try {
    check();
  } catch (const OptionError& error) {
    // By the member; else by the flag an inner manager (a check on a
    // registered copy) already named, which this one may know by an alias.
    const Option* named = nullptr;
    for (const Option& option : options_) {
      if (option.address == error.field()) named = &option;
    }
    for (const Option& option : options_) {
      if (named == nullptr && option.address != nullptr &&
          option.name == error.name()) {
        named = &option;
      }
    }
    if (named == nullptr) throw;
    throw OptionError(error.field(), FlagName(*named), error.problem());
  }
}

std::vector<std::pair<std::string, std::string>> OptionManager::Options()
    const {
  std::vector<std::pair<std::string, std::string>> options;
  for (const Option& option : options_) {
    if (option.target < 0 && !option.foreign) {
      options.emplace_back(option.name, option.type);
    }
  }
  return options;
}

bool OptionManager::IsSet(const std::string& name) const {
  const Option* option = Find(name);
  if (option == nullptr) return false;
  return option->target >= 0 ? options_[option->target].set : option->set;
}

OptionManager::Option* OptionManager::Find(const std::string& name) {
  for (Option& option : options_) {
    if (option.name == name) return &option;
  }
  return nullptr;
}

const OptionManager::Option* OptionManager::Find(
    const std::string& name) const {
  for (const Option& option : options_) {
    if (option.name == name) return &option;
  }
  return nullptr;
}

std::string OptionManager::FlagName(const Option& option) {
  return option.set_as.empty() ? option.name : option.set_as;
}

void OptionManager::AddAlias(const std::string& alias,
                             const std::string& name) {
  const Option* target = Find(name);
  if (target == nullptr || target->target >= 0 || target->foreign) {
    throw std::logic_error("alias --" + alias + " of --" + name +
                           ", which is not registered");
  }
  const int index = static_cast<int>(target - options_.data());
  AddOption(alias, "COLMAP 4's name of --" + name, target->type, "", nullptr,
            nullptr, nullptr)
      .target = index;
}

void OptionManager::AddFixed(const std::string& name, bool value,
                             const std::string& note) {
  Option& option = AddOption(name, note, "bool", value ? "1" : "0", nullptr,
                             nullptr, nullptr);
  option.foreign = true;
  option.fixed_value = value ? "1" : "0";
  option.unsupported = std::string("only ") + (value ? "1" : "0") +
                       " is supported (" + note + ")";
}

void OptionManager::AddUnsupported(const std::string& name,
                                   const std::string& note) {
  Option& option = AddOption(name, note, "", "", nullptr, nullptr, nullptr);
  option.foreign = true;
  option.unsupported = "not supported by colmap_irav4 (" + note + ")";
}

void OptionManager::Write(std::ostream& stream) const {
  // Options without a section first, then each section once, in the order
  // of registration.
  std::vector<std::string> sections = {""};
  for (const Option& option : options_) {
    if (option.target >= 0 || option.foreign) continue;
    const size_t dot = option.name.find('.');
    const std::string section =
        dot == std::string::npos ? "" : option.name.substr(0, dot);
    if (std::find(sections.begin(), sections.end(), section) ==
        sections.end()) {
      sections.push_back(section);
    }
  }
  for (const std::string& section : sections) {
    if (!section.empty()) stream << "[" << section << "]\n";
    for (const Option& option : options_) {
      if (option.target >= 0 || option.foreign) continue;
      const size_t dot = option.name.find('.');
      if ((dot == std::string::npos ? "" : option.name.substr(0, dot)) !=
          section) {
        continue;
      }
      stream << (dot == std::string::npos ? option.name
                                          : option.name.substr(dot + 1))
             << "=" << option.value() << "\n";
    }
  }
}

void OptionManager::PrintHelp(std::ostream& stream) const {
  stream << "Usage: colmap_irav4 " << command_name_ << " [options]\n";
  if (!description_.empty()) stream << "\n" << description_ << "\n";
  stream << "\nOptions:\n";
  for (const Option& option : options_) {
    if (option.target >= 0 || option.foreign) continue;
    stream << "  --" << option.name << " arg";
    if (option.required) {
      stream << " (required)";
    } else {
      stream << " (=" << option.default_value << ")";
    }
    stream << "\n      " << option.help << "\n";
  }
  bool foreign_header = false;
  for (const Option& option : options_) {
    if (option.target < 0 && !option.foreign) continue;
    if (!foreign_header) {
      stream << "\nCOLMAP 4's flags (ours where the meaning is the same):\n";
      foreign_header = true;
    }
    stream << "  --" << option.name << ": ";
    if (option.target >= 0) {
      stream << "--" << options_[option.target].name << "\n";
    } else if (!option.fixed_value.empty()) {
      stream << "only " << option.fixed_value << " (" << option.help << ")\n";
    } else {
      stream << "not supported (" << option.help << ")\n";
    }
  }
}

}  // namespace colmap_irav4
