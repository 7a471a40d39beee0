#include "colmap_irav4/util/option_manager.h"

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
