// `colmap_irav4 help` lists the commands; `colmap_irav4 help <command>` prints
// that command's help (as `colmap_irav4 <command> -h`).

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

#include "tests/test_utils/database_test_utils.h"

namespace colmap_irav4 {
namespace {

struct RunResult {
  int exit_code = -1;
  std::string output;
};

RunResult RunProgram(const std::string& arguments) {
  test::TempDir temp;
  const std::string log = temp.File("run.log");
  const int status = std::system((std::string(COLMAP_IRAV4_BINARY) + " " +
                                  arguments + " > " + log + " 2>&1")
                                     .c_str());
  RunResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream file(log);
  result.output.assign(std::istreambuf_iterator<char>(file),
                       std::istreambuf_iterator<char>());
  return result;
}

TEST(HelpCommand, HelpListsTheCommands) {
  const RunResult result = RunProgram("help");
  EXPECT_EQ(result.exit_code, 0);
  EXPECT_NE(result.output.find("Commands:"), std::string::npos);
  for (const char* command :
       {"mapper", "rotation_averager", "view_graph", "model_comparer"}) {
    EXPECT_NE(result.output.find(std::string("  ") + command),
              std::string::npos)
        << command;
  }
}

TEST(HelpCommand, HelpMapperPrintsTheMappersHelp) {
  const RunResult help = RunProgram("help mapper");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.output.find("Usage: colmap_irav4 mapper"), std::string::npos)
      << help.output;
  EXPECT_NE(help.output.find("--Mapper.num_threads"), std::string::npos);
  EXPECT_EQ(help.output.find("Commands:"), std::string::npos);
  // The same text as `mapper -h`.
  EXPECT_EQ(help.output, RunProgram("mapper -h").output);
}

TEST(HelpCommand, GlobalMapperTakesColmap4sFlags) {
  const RunResult help = RunProgram("help global_mapper");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(
      help.output.find("--GlobalMapper.num_threads: --Mapper.num_threads"),
      std::string::npos)
      << help.output;
  // mapper's help lists ours only.
  EXPECT_EQ(RunProgram("mapper -h").output.find("GlobalMapper"),
            std::string::npos);
  // A COLMAP 4 flag ours does not support: exit 1, named, before any work.
  test::TempDir temp;
  const RunResult unsupported = RunProgram(
      "global_mapper --database_path " + temp.File("none.db") +
      " --output_path " + temp.File("out") + " --GlobalMapper.gp_gpu_index 0");
  EXPECT_EQ(unsupported.exit_code, 1);
  EXPECT_NE(unsupported.output.find(
                "ERROR: --GlobalMapper.gp_gpu_index: not supported"),
            std::string::npos)
      << unsupported.output;
  // A bad value under COLMAP 4's name is named so.
  const RunResult bad = RunProgram(
      "global_mapper --database_path " + temp.File("none.db") +
      " --output_path " + temp.File("out") + " --GlobalMapper.random_seed -1");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.output.find("ERROR: --GlobalMapper.random_seed: must be >= 0"),
            std::string::npos)
      << bad.output;
}

TEST(HelpCommand, HelpOfAnUnknownCommandFails) {
  const RunResult result = RunProgram("help no_such_command");
  EXPECT_NE(result.exit_code, 0);
  EXPECT_NE(result.output.find("unknown command 'no_such_command'"),
            std::string::npos)
      << result.output;
}

}  // namespace
}  // namespace colmap_irav4
