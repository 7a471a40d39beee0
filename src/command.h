#pragma once

#include <functional>
#include <map>
#include <string>

namespace colmap_irav4 {

// A sub-command of the colmap_irav4 program: argv[0] is the command's name.
// Returns the process exit code. Throw InputError for bad input; main() prints
// it as one line and exits with 1.
using CommandFunction = std::function<int(int argc, char** argv)>;

struct CommandInfo {
  std::string description;
  CommandFunction function;
};

std::map<std::string, CommandInfo>& CommandRegistry();

// Registers a command at static-initialisation time; one per src/*_command.cc:
//   static CommandRegistrar registrar("view_graph", "Exports ...",
//   RunViewGraph);
struct CommandRegistrar {
  CommandRegistrar(const std::string& name, const std::string& description,
                   CommandFunction function) {
    CommandRegistry()[name] = CommandInfo{description, std::move(function)};
  }
};

}  // namespace colmap_irav4
