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

TEST(MapperOptions, ForStagesSetsEveryStagesCopyOfASharedSetting) {
  GlobalMapperOptions options;
  options.view_graph.min_num_inliers = 30;  // --Mapper.min_num_matches
  options.num_threads = 3;
  options.seed = 9;
  options.skip_retriangulation = true;
  const GlobalMapperOptions stages = options.ForStages(10);
  // The fold check counts a pair as matched as the view graph keeps it.
  EXPECT_EQ(stages.fold.detection.min_num_matches, 30);
  EXPECT_EQ(stages.view_graph.num_threads, 3);
  EXPECT_EQ(stages.bundle_adjustment.solver.ceres.num_threads, 3);
  EXPECT_EQ(stages.rotation_averaging.irav4.seed, 9);
  // Without retriangulation positioning takes every track.
  EXPECT_EQ(stages.positioning_tracks.tracks_per_image, 0);
  EXPECT_EQ(options.positioning_tracks.tracks_per_image, 500);
  // Applying it again changes nothing.
  const GlobalMapperOptions again = stages.ForStages(10);
  EXPECT_EQ(again.fold.detection.min_num_matches, 30);
  EXPECT_EQ(again.triangulation.random_seed, 9u);
}

TEST(MapperOptions, CheckNamesTheFlagWithoutAManager) {
  // Check() alone (the pipeline's one check) names the registered flag.
  GlobalMapperOptions options;
  options.view_graph.min_num_inliers = -1;
  try {
    options.Check();
    FAIL();
  } catch (const InputError& error) {
    EXPECT_EQ(std::string(error.what()).rfind("--Mapper.min_num_matches: ", 0),
              0u)
        << error.what();
  }
  options = GlobalMapperOptions();
  options.positioning_tracks.grid_size = 0;
  try {
    options.Check();
    FAIL();
  } catch (const InputError& error) {
    EXPECT_EQ(
        std::string(error.what()).rfind("--Mapper.positioning_grid_size: ", 0),
        0u)
        << error.what();
  }
}

TEST(MapperOptions, IniHoldsEveryFlagWithItsExactValue) {
  GlobalMapperOptions options;
  options.view_graph.min_num_inliers = 30;
  options.rotation_filter.max_rotation_error_deg = 0.1234567890123;
  const std::string ini = GlobalMapperOptionsIni(options);
  EXPECT_EQ(ini.rfind("[Mapper]\nmin_model_size=3\n", 0), 0u) << ini;
  EXPECT_NE(ini.find("\nmin_num_matches=30\n"), std::string::npos) << ini;
  EXPECT_NE(ini.find("\n[RotationFilter]\nmax_rotation_error_deg="
                     "0.1234567890123\n"),
            std::string::npos)
      << ini;
  // One line per flag, plus one per section.
  OptionManager manager("mapper");
  GlobalMapperOptions registered;
  AddGlobalMapperOptions(&manager, &registered);
  size_t num_lines = 0;
  size_t num_sections = 0;
  for (size_t k = 0; k < ini.size(); ++k) {
    if (ini[k] != '\n') continue;
    ++num_lines;
    if (k + 1 < ini.size() && ini[k + 1] == '[') ++num_sections;
  }
  EXPECT_EQ(num_lines, manager.Options().size() + num_sections + 1);
}

}  // namespace
}  // namespace colmap_irav4
