// The options contract of the mapper: every registered flag, given a bad
// value, is rejected with an error that names exactly that flag (by the
// parser for malformed values, by the options structs' Check() otherwise).

#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "colmap_irav4/pipeline/global_mapper.h"
#include "colmap_irav4/pipeline/option_registration.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"

namespace colmap_irav4 {
namespace {

// Parses `flags` into fresh mapper options (with COLMAP 4's names of
// global_mapper too when `colmap4`) and checks them. Returns the error
// message, or "" and the options in *options when they were accepted.
std::string Parse(const std::vector<std::string>& flags, bool colmap4,
                  GlobalMapperOptions* options) {
  OptionManager manager(colmap4 ? "global_mapper" : "mapper");
  AddGlobalMapperOptions(&manager, options);
  if (colmap4) AddColmap4GlobalMapperFlags(&manager);
  std::vector<std::string> args = {"mapper"};
  args.insert(args.end(), flags.begin(), flags.end());
  std::vector<char*> argv;
  for (std::string& arg : args) argv.push_back(arg.data());
  try {
    manager.Parse(static_cast<int>(argv.size()), argv.data());
    manager.Check([&] { options->Check(); });
  } catch (const InputError& error) {
    return error.what();
  }
  return "";
}

// Parses `--flag value` into fresh mapper options and checks them. Returns
// the error message, or "" when the value was accepted.
std::string TryValue(const std::string& flag, const std::string& value) {
  GlobalMapperOptions options;
  return Parse({"--" + flag, value}, /*colmap4=*/false, &options);
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

TEST(MapperOptions, ChoicesAreParsedByNameAndListTheAllowedOnes) {
  EXPECT_EQ(TryValue("TranslationAveraging.cost", "l2"),
            "--TranslationAveraging.cost: must be bata or chordal, got 'l2'");
  EXPECT_EQ(TryValue("BundleAdjustment.loss_function", "cauchy"), "");
  EXPECT_EQ(TryValue("Mapper.positioning_method", "translation_averaging"), "");
  // project.ini writes a choice by its name.
  GlobalMapperOptions options;
  options.translation_averaging.cost = TranslationAveragingCost::kChordal;
  EXPECT_NE(GlobalMapperOptionsIni(options).find(
                "[TranslationAveraging]\ncost=chordal\n"),
            std::string::npos);
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

TEST(MapperOptions, UnregisteredSettingsAreNamedAsMembers) {
  // A setting no command registers is named as its member, never as a flag
  // that does not exist; a registered one by its flag.
  GlobalMapperOptions options;
  options.fold.detection.max_scale_ratio = 0.5;
  try {
    options.Check();
    FAIL();
  } catch (const InputError& error) {
    EXPECT_EQ(std::string(error.what())
                  .rfind("FoldDetectionOptions::max_scale_ratio: ", 0),
              0u)
        << error.what();
  }
  options = GlobalMapperOptions();
  options.fold.detection.max_fold_score = 2;
  try {
    options.Check();
    FAIL();
  } catch (const InputError& error) {
    EXPECT_EQ(std::string(error.what()).rfind("--Fold.max_fold_score: ", 0), 0u)
        << error.what();
  }
  options = GlobalMapperOptions();
  options.part_merge.min_met_points = 1;
  try {
    options.Check();
    FAIL();
  } catch (const InputError& error) {
    EXPECT_EQ(
        std::string(error.what()).rfind("--PartMerge.min_met_points: ", 0), 0u)
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

// Parses `flags` into fresh mapper options under the global_mapper command's
// names (ours and COLMAP 4's) and checks them; the options' project.ini, or
// the error message prefixed by "ERROR ".
std::string ParseGlobalMapper(const std::vector<std::string>& flags) {
  GlobalMapperOptions options;
  const std::string error = Parse(flags, /*colmap4=*/true, &options);
  return error.empty() ? GlobalMapperOptionsIni(options) : "ERROR " + error;
}

// A valid value other than the default, for every flag COLMAP 4 names.
const std::map<std::string, std::string>& Colmap4Values() {
  static const std::map<std::string, std::string> values = {
      {"GlobalMapper.min_num_matches", "31"},
      {"GlobalMapper.num_threads", "3"},
      {"GlobalMapper.random_seed", "7"},
      {"GlobalMapper.ba_num_iterations", "4"},
      {"GlobalMapper.skip_bundle_adjustment", "1"},
      {"GlobalMapper.skip_retriangulation", "1"},
      {"GlobalMapper.track_intra_image_consistency_threshold", "10"},
      {"GlobalMapper.track_min_num_views_per_track", "3"},
      {"GlobalMapper.keep_max_num_tracks", "2147483647"},
      {"GlobalMapper.gp_loss_function_scale", "0.25"},
      {"GlobalMapper.gp_max_num_iterations", "77"},
      {"GlobalMapper.ba_refine_focal_length", "0"},
      {"GlobalMapper.ba_refine_principal_point", "1"},
      {"GlobalMapper.ba_refine_extra_params", "0"},
      {"GlobalMapper.ba_ceres_loss_function_scale", "2.5"},
      {"GlobalMapper.ba_ceres_max_num_iterations", "55"},
      {"GlobalMapper.tri_min_angle", "1"},
      {"GlobalMapper.ra_max_rotation_error_deg", "7.5"},
      {"GlobalMapper.max_angular_reproj_error_deg", "1"},
      {"GlobalMapper.min_tri_angle_deg", "1"},
  };
  return values;
}

TEST(GlobalMapperFlags, Colmap4NamesParseIntoTheSameOptionsAsOurs) {
  std::vector<std::string> colmap4;
  std::vector<std::string> ours;
  size_t num_aliases = 0;
  for (const Colmap4Flag& flag : Colmap4GlobalMapperFlags()) {
    if (flag.ours.empty()) continue;
    ++num_aliases;
    const auto value = Colmap4Values().find(flag.colmap4);
    ASSERT_NE(value, Colmap4Values().end()) << flag.colmap4;
    colmap4.insert(colmap4.end(), {"--" + flag.colmap4, value->second});
    ours.insert(ours.end(), {"--" + flag.ours, value->second});
  }
  EXPECT_EQ(num_aliases, Colmap4Values().size());
  const std::string colmap4_ini = ParseGlobalMapper(colmap4);
  EXPECT_EQ(colmap4_ini.rfind("ERROR", 0), std::string::npos) << colmap4_ini;
  EXPECT_EQ(colmap4_ini, ParseGlobalMapper(ours));
  // Every value took effect: each differs from the default.
  EXPECT_NE(colmap4_ini, GlobalMapperOptionsIni(GlobalMapperOptions()));
  for (size_t k = 0; k + 1 < colmap4.size(); k += 2) {
    EXPECT_NE(ParseGlobalMapper({colmap4[k], colmap4[k + 1]}),
              GlobalMapperOptionsIni(GlobalMapperOptions()))
        << colmap4[k];
  }
}

TEST(GlobalMapperFlags, UnsupportedOnesAreNamedInTheError) {
  size_t num_rejected = 0;
  for (const Colmap4Flag& flag : Colmap4GlobalMapperFlags()) {
    if (!flag.ours.empty()) continue;
    SCOPED_TRACE(flag.colmap4);
    if (flag.fixed >= 0) {
      // Accepted with the value ours implements, rejected with the other.
      const std::string same = flag.fixed == 1 ? "1" : "0";
      const std::string other = flag.fixed == 1 ? "0" : "1";
      EXPECT_EQ(ParseGlobalMapper({"--" + flag.colmap4, same}),
                GlobalMapperOptionsIni(GlobalMapperOptions()));
      const std::string message =
          ParseGlobalMapper({"--" + flag.colmap4, other});
      EXPECT_EQ(message.rfind("ERROR --" + flag.colmap4 + ": only " + same, 0),
                0u)
          << message;
    } else {
      const std::string message = ParseGlobalMapper({"--" + flag.colmap4, "1"});
      EXPECT_EQ(message.rfind("ERROR --" + flag.colmap4 + ": not supported", 0),
                0u)
          << message;
    }
    ++num_rejected;
  }
  EXPECT_GT(num_rejected, 20u);
}

TEST(GlobalMapperFlags, ErrorsNameTheFlagAsTyped) {
  // Check()'s error about the member names COLMAP 4's flag when given so.
  std::string message = ParseGlobalMapper({"--GlobalMapper.random_seed", "-1"});
  EXPECT_EQ(message.rfind("ERROR --GlobalMapper.random_seed: ", 0), 0u)
      << message;
  message = ParseGlobalMapper({"--Mapper.seed", "-1"});
  EXPECT_EQ(message.rfind("ERROR --Mapper.seed: ", 0), 0u) << message;
  // A malformed value too.
  message = ParseGlobalMapper({"--GlobalMapper.num_threads", "x"});
  EXPECT_EQ(message.rfind("ERROR --GlobalMapper.num_threads: ", 0), 0u)
      << message;
  // Both names of one setting: refused.
  message = ParseGlobalMapper(
      {"--Mapper.num_threads", "2", "--GlobalMapper.num_threads", "3"});
  EXPECT_EQ(message.rfind("ERROR --GlobalMapper.num_threads: sets the same "
                          "option as --Mapper.num_threads",
                          0),
            0u)
      << message;
  // Unknown names stay unknown.
  message = ParseGlobalMapper({"--GlobalMapper.no_such_flag", "1"});
  EXPECT_EQ(message.rfind("ERROR --GlobalMapper.no_such_flag: unknown", 0), 0u)
      << message;
}

TEST(GlobalMapperFlags, UsageDocumentsEveryColmap4Flag) {
  std::ifstream file(std::string(COLMAP_IRAV4_SOURCE_DIR) + "/docs/usage.md");
  const std::string usage((std::istreambuf_iterator<char>(file)),
                          std::istreambuf_iterator<char>());
  ASSERT_FALSE(usage.empty());
  for (const Colmap4Flag& flag : Colmap4GlobalMapperFlags()) {
    const std::string row =
        "| `--" + flag.colmap4 + "` | " +
        (flag.ours.empty()
             ? (flag.fixed >= 0 ? "only " + std::to_string(flag.fixed)
                                : std::string("not supported"))
             : "`--" + flag.ours + "`") +
        " |";
    EXPECT_NE(usage.find(row), std::string::npos) << row;
  }
}

}  // namespace
}  // namespace colmap_irav4
