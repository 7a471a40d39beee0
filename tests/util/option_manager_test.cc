#include "colmap_irav4/util/option_manager.h"

#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

int Parse(OptionManager* options, std::vector<std::string> args) {
  std::vector<char*> argv;
  for (std::string& arg : args) argv.push_back(arg.data());
  return options->Parse(static_cast<int>(argv.size()), argv.data());
}

TEST(OptionManager, ParsesDottedOptions) {
  std::string path;
  double theta = 3.0;
  int count = 5;
  bool flag = false;
  OptionManager options("test");
  options.AddRequired("database_path", &path, "db");
  options.Add("RotationAveraging.theta_deg", &theta, "theta");
  options.Add("Mapper.count", &count, "count");
  options.Add("Mapper.flag", &flag, "flag");
  EXPECT_TRUE(Parse(&options, {"test", "--database_path", "a.db",
                               "--RotationAveraging.theta_deg=2.5",
                               "--Mapper.flag", "--Mapper.count", "7"}));
  EXPECT_EQ(path, "a.db");
  EXPECT_EQ(theta, 2.5);
  EXPECT_EQ(count, 7);
  EXPECT_TRUE(flag);
  EXPECT_TRUE(options.IsSet("Mapper.count"));
}

TEST(OptionManager, WritesTheCurrentValuesAsProjectIni) {
  std::string path = "a.db";
  double theta = 0.1;
  int count = 5;
  bool flag = true;
  OptionManager options("test");
  options.Add("Mapper.count", &count, "count");
  options.AddRequired("database_path", &path, "db");
  options.Add("RotationAveraging.theta_deg", &theta, "theta");
  options.Add("Mapper.flag", &flag, "flag");
  count = 7;
  theta = 1.0 / 3.0;
  std::ostringstream ini;
  options.Write(ini);
  // Unsectioned first, then each section once in registration order; the
  // values as they are now, doubles exactly.
  EXPECT_EQ(ini.str(),
            "database_path=a.db\n[Mapper]\ncount=7\nflag=1\n"
            "[RotationAveraging]\ntheta_deg=0.3333333333333333\n");
  EXPECT_EQ(std::stod("0.3333333333333333"), theta);
}

TEST(OptionManager, RejectsBadInput) {
  std::string path;
  int count = 5;
  OptionManager options("test");
  options.AddRequired("database_path", &path, "db");
  options.Add("count", &count, "count");
  EXPECT_THROW(Parse(&options, {"test"}), InputError);
  EXPECT_THROW(Parse(&options, {"test", "--database_path", "a", "--nope", "1"}),
               InputError);
  EXPECT_THROW(
      Parse(&options, {"test", "--database_path", "a", "--count", "7x"}),
      InputError);
  EXPECT_THROW(Parse(&options, {"test", "--database_path"}), InputError);
  // A required path given as '' (issue 28: an unset shell variable).
  try {
    Parse(&options, {"test", "--database_path", ""});
    ADD_FAILURE() << "an empty required path was accepted";
  } catch (const InputError& error) {
    EXPECT_EQ(std::string(error.what()), "--database_path: is empty");
  }
  EXPECT_FALSE(Parse(&options, {"test", "-h"}));
}

}  // namespace
}  // namespace colmap_irav4
