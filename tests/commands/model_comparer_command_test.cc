// `colmap_irav4 model_comparer`: COLMAP 3.8's model of fountain-P11 against
// the ground truth cameras and against itself, and its input errors.

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/test_utils/data.h"
#include "tests/test_utils/database_test_utils.h"

namespace colmap_irav4 {
namespace {

struct RunResult {
  int exit_code = -1;
  std::string output;
};

RunResult RunComparer(const std::string& arguments, const test::TempDir& temp) {
  const std::string log = temp.File("run.log");
  const int status =
      std::system((std::string(COLMAP_IRAV4_BINARY) + " model_comparer " +
                   arguments + " > " + log + " 2>&1")
                      .c_str());
  RunResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream file(log);
  result.output.assign(std::istreambuf_iterator<char>(file),
                       std::istreambuf_iterator<char>());
  return result;
}

// The number after `label` in `text` (NaN if absent).
double FigureAfter(const std::string& text, const std::string& label) {
  const size_t at = text.find(label);
  if (at == std::string::npos) return std::nan("");
  return std::stod(text.substr(at + label.size()));
}

const std::string kScene = DataDir() + "/strecha/fountain-P11";

TEST(ModelComparerCommand, ColmapModelAgainstGroundTruth) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/fountain-P11");
  test::TempDir temp;
  const RunResult run = RunComparer("--input_path1 " + kScene +
                                        "/colmap38_incremental --gt_path " +
                                        kScene + "/gt_cameras",
                                    temp);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("11 registered images"), std::string::npos)
      << run.output;
  EXPECT_NE(run.output.find("alignment inliers: 11"), std::string::npos);
  // The data README: about 0.05 deg and 2.5 mm.
  const double rotation =
      FigureAfter(run.output, "rotation error [deg]: median ");
  const double centre = FigureAfter(run.output, "centre error: median ");
  EXPECT_GT(rotation, 0.0);
  EXPECT_LT(rotation, 0.1) << run.output;
  EXPECT_GT(centre, 0.0);
  EXPECT_LT(centre, 0.005) << run.output;
}

TEST(ModelComparerCommand, ModelAgainstItselfHasNoError) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/fountain-P11");
  test::TempDir temp;
  const std::string model = kScene + "/colmap38_incremental";
  const RunResult run =
      RunComparer("--input_path1 " + model + " --input_path2 " + model, temp);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_LT(FigureAfter(run.output, "rotation error [deg]: median "), 1e-6);
  EXPECT_LT(FigureAfter(run.output, "centre error: median "), 1e-6);
  EXPECT_NEAR(FigureAfter(run.output, "alignment scale: "), 1.0, 1e-6);
}

TEST(ModelComparerCommand, PerImageListsEveryImageWorstFirst) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/castle-P19");
  const std::string scene = DataDir() + "/strecha/castle-P19";
  test::TempDir temp;
  const RunResult run = RunComparer("--input_path1 " + scene +
                                        "/colmap38_incremental --gt_path " +
                                        scene + "/gt_cameras --per_image",
                                    temp);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const size_t header = run.output.find("per image, worst first");
  ASSERT_NE(header, std::string::npos) << run.output;
  std::istringstream lines(run.output.substr(header));
  std::string line;
  std::getline(lines, line);
  std::set<std::string> names;
  double previous = 180;
  std::string first;
  while (std::getline(lines, line)) {
    std::istringstream fields(line);
    std::string name;
    double rotation_only = -1, rotation = -1, centre = -1;
    fields >> name >> rotation_only >> rotation >> centre;
    ASSERT_FALSE(fields.fail()) << line;
    EXPECT_LE(rotation_only, previous) << line;
    EXPECT_GE(rotation, 0);
    EXPECT_GE(centre, 0);
    previous = rotation_only;
    if (first.empty()) first = name;
    names.insert(name);
  }
  EXPECT_EQ(names.size(), 19u) << run.output;
  // COLMAP 3.8's worst camera there: 0015, 0.64 deg off (rotation only).
  EXPECT_EQ(first, "0015.jpg") << run.output;
  EXPECT_NEAR(FigureAfter(run.output, "0015.jpg "), 0.64, 0.01);
}

TEST(ModelComparerCommand, NeedsExactlyOneReference) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/fountain-P11");
  test::TempDir temp;
  const std::string model = kScene + "/colmap38_incremental";
  RunResult run = RunComparer("--input_path1 " + model, temp);
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("--input_path2/--gt_path"), std::string::npos)
      << run.output;
  run = RunComparer(
      "--input_path1 " + temp.File("nothing") + " --input_path2 " + model,
      temp);
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find(temp.File("nothing")), std::string::npos)
      << run.output;
}

}  // namespace
}  // namespace colmap_irav4
