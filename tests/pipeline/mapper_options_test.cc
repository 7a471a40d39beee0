// The options contract of the mapper: every registered flag, given a bad
// value, is rejected with an error that names exactly that flag (by the
// parser for malformed values, by the options structs' Check() otherwise).

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "colmap_irav4/pipeline/global_mapper.h"
#include "colmap_irav4/pipeline/option_registration.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"

namespace colmap_irav4 {
namespace {

// Parses `--flag value` into fresh mapper options and checks them. Returns
// the error message, or "" when the value was accepted.
std::string TryValue(const std::string& flag, const std::string& value) {
  GlobalMapperOptions options;
  OptionManager manager("mapper");
  AddGlobalMapperOptions(&manager, &options);
  std::vector<std::string> args = {"mapper", "--" + flag, value};
  std::vector<char*> argv;
  for (std::string& arg : args) argv.push_back(arg.data());
  try {
    manager.Parse(static_cast<int>(argv.size()), argv.data());
    manager.Check([&] { options.Check(); });
  } catch (const InputError& error) {
    return error.what();
  }
  return "";
}

TEST(MapperOptions, EveryFlagWithABadValueIsRejectedNamingThatFlag) {
  GlobalMapperOptions options;
  OptionManager manager("mapper");
  AddGlobalMapperOptions(&manager, &options);
  const auto flags = manager.Options();
  ASSERT_GT(flags.size(), 60u);
  int num_checked = 0;
  for (const auto& [flag, type] : flags) {
    SCOPED_TRACE("--" + flag + " (" + type + ")");
    // Candidates in order; the first that is rejected must name the flag.
    std::vector<std::string> bad_values;
    if (type == "bool") {
      bad_values = {"maybe"};
    } else if (type == "int") {
      bad_values = {"-1000000000", "2.5"};
    } else if (type == "double") {
      bad_values = {"-1e9", "1e9", "x"};
    } else {
      bad_values = {"no_such_value"};
    }
    std::string message;
    std::string rejected_value;
    for (const std::string& value : bad_values) {
      message = TryValue(flag, value);
      if (!message.empty()) {
        rejected_value = value;
        break;
      }
    }
    ASSERT_FALSE(message.empty())
        << "--" << flag << " accepts every bad value tried";
    // Numbers are rejected by Check(), not only malformed ones by the parser.
    if ((type == "int" || type == "double") && rejected_value != "-1e9" &&
        rejected_value != "1e9" && rejected_value != "-1000000000") {
      ADD_FAILURE() << "--" << flag << " accepts -1e9 and 1e9";
    }
    // The message starts with the flag, e.g. "--Mapper.num_threads: ...".
    EXPECT_EQ(message.rfind("--" + flag + ":", 0), 0u)
        << "--" << flag << " " << rejected_value << " -> " << message;
    ++num_checked;
  }
  EXPECT_EQ(num_checked, static_cast<int>(flags.size()));
}

TEST(MapperOptions, MinNumMatchesIsNamedAsTyped) {
  const std::string message = TryValue("Mapper.min_num_matches", "-1");
  EXPECT_EQ(message.rfind("--Mapper.min_num_matches: ", 0), 0u) << message;
  EXPECT_EQ(message.find("ViewGraph"), std::string::npos) << message;
}

TEST(MapperOptions, EveryMemberRegisteredOnce) {
  // A second registration of a member (by name or address) is refused.
  GlobalMapperOptions options;
  OptionManager manager("mapper");
  AddGlobalMapperOptions(&manager, &options);
  EXPECT_THROW(manager.Add("Other.min_model_size", &options.min_model_size, ""),
               std::logic_error);
  EXPECT_THROW(manager.Add("Mapper.min_model_size", &options.num_threads, ""),
               std::logic_error);
}

TEST(MapperOptions, DefaultsPass) {
  GlobalMapperOptions options;
  OptionManager manager("mapper");
  AddGlobalMapperOptions(&manager, &options);
  EXPECT_NO_THROW(manager.Check([&] { options.Check(); }));
}

}  // namespace
}  // namespace colmap_irav4
