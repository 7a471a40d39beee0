// colmap_irav4: a global Structure-from-Motion mapper for COLMAP databases.
// Sub-commands in COLMAP's style: `colmap_irav4 <command> [--options]`.

#include <signal.h>

#include <exception>
#include <iostream>
#include <string>

#include <glog/logging.h>

#include "colmap_irav4/util/error.h"
#include "src/command.h"

namespace colmap_irav4 {

std::map<std::string, CommandInfo>& CommandRegistry() {
  static std::map<std::string, CommandInfo> registry;
  return registry;
}

namespace {

void PrintUsage() {
  std::cout << "colmap_irav4 -- global Structure-from-Motion with IRAv4 "
               "rotation averaging\n\n"
               "Usage:\n"
               "  colmap_irav4 help\n"
               "  colmap_irav4 help <command>\n"
               "  colmap_irav4 <command> -h\n"
               "  colmap_irav4 <command> [--option value ...]\n\n"
               "Commands:\n";
  for (const auto& [name, info] : CommandRegistry()) {
    std::cout << "  " << name;
    for (size_t i = name.size(); i < 20; ++i) std::cout << ' ';
    std::cout << info.description << "\n";
  }
}

// The message on one line: control characters (a newline in an image name
// or a path) escaped.
std::string OneLine(const std::string& message) {
  std::string line;
  for (const char c : message) {
    if (c == '\n') {
      line += "\\n";
    } else if (c == '\r') {
      line += "\\r";
    } else if (c == '\t') {
      line += "\\t";
    } else if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
      const char* digits = "0123456789abcdef";
      line += std::string("\\x") + digits[(c >> 4) & 0xf] + digits[c & 0xf];
    } else {
      line += c;
    }
  }
  return line;
}

}  // namespace
}  // namespace colmap_irav4

int main(int argc, char** argv) {
  using namespace colmap_irav4;
  // A closed stdout/stderr (`mapper 2>&1 | head`) must not kill the run and
  // lose its output: writes to it fail quietly instead.
  signal(SIGPIPE, SIG_IGN);
  google::InitGoogleLogging(argv[0]);
  FLAGS_logtostderr = true;
  if (argc < 2) {
    PrintUsage();
    return 1;
  }
  const std::string command = argv[1];
  if ((command == "help" || command == "-h" || command == "--help") &&
      argc < 3) {
    PrintUsage();
    return 0;
  }
  // `colmap_irav4 help mapper`: the command's own help (as `mapper -h`).
  const bool command_help =
      command == "help" || command == "-h" || command == "--help";
  const std::string name = command_help ? argv[2] : command;
  const auto it = CommandRegistry().find(name);
  if (it == CommandRegistry().end()) {
    std::cerr << "ERROR: unknown command '" << name
              << "' (see colmap_irav4 help)" << std::endl;
    return 1;
  }
  try {
    if (command_help) {
      std::string help_flag = "-h";
      char* help_argv[] = {argv[2], help_flag.data(), nullptr};
      return it->second.function(2, help_argv);
    }
    return it->second.function(argc - 1, argv + 1);
  } catch (const InputError& error) {
    std::cerr << "ERROR: " << OneLine(error.what()) << std::endl;
    return 1;
  } catch (const std::exception& error) {
    std::cerr << "ERROR: " << command << ": " << OneLine(error.what())
              << std::endl;
    return 1;
  }
}
