// End-to-end: the colmap_irav4 binary's view_graph command on real and bad
// databases.

#include <sys/wait.h>

#include <cstdio>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/strecha_gt.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/io/database_writer.h"
#include "tests/test_utils/data.h"
#include "tests/test_utils/database_test_utils.h"
#include "tests/test_utils/record.h"

namespace colmap_irav4 {
namespace {

using test::HashFile;
using test::TempDir;

const std::string kBinary = COLMAP_IRAV4_BINARY;
const std::string kDataDir = DataDir();
const std::string kSourceDir = COLMAP_IRAV4_SOURCE_DIR;

struct RunResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

std::string ReadText(const std::string& path) {
  std::ifstream file(path);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream stream(text);
  std::string line;
  while (std::getline(stream, line)) lines.push_back(line);
  return lines;
}

RunResult RunCommand(const TempDir& dir, const std::string& args) {
  const std::string out = dir.File("stdout.txt");
  const std::string err = dir.File("stderr.txt");
  const std::string command =
      "'" + kBinary + "' " + args + " > '" + out + "' 2> '" + err + "'";
  const int status = std::system(command.c_str());
  RunResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.out = ReadText(out);
  result.err = ReadText(err);
  return result;
}

TEST(ViewGraphCommand, BundledExampleWritesRelativePoses) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/fountain-P11/gt_cameras");
  TempDir dir;
  const std::string database = kSourceDir + "/tests/data/fountain-P11.db";
  const uint64_t hash = HashFile(database);
  const std::string output = dir.File("relpose.txt");
  const RunResult result =
      RunCommand(dir, "view_graph --database_path '" + database +
                          "' --output_path '" + output + "'");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(HashFile(database), hash);
  EXPECT_NE(result.out.find("pairs kept:           55"), std::string::npos)
      << result.out;
  EXPECT_FALSE(std::filesystem::exists(output + ".tmp"));
  const auto gt =
      ReadStrechaGroundTruth(kDataDir + "/strecha/fountain-P11/gt_cameras");
  const std::vector<std::string> lines = Lines(ReadText(output));
  ASSERT_EQ(lines.size(), 55u);
  std::vector<double> errors;
  for (const std::string& line : lines) {
    std::istringstream stream(line);
    std::string name1, name2;
    Eigen::Vector4d q;
    Eigen::Vector3d t;
    int inliers = 0;
    ASSERT_TRUE(stream >> name1 >> name2 >> q(0) >> q(1) >> q(2) >> q(3) >>
                t(0) >> t(1) >> t(2) >> inliers)
        << line;
    std::string extra;
    EXPECT_FALSE(stream >> extra) << line;
    EXPECT_NEAR(q.norm(), 1.0, 1e-9);
    EXPECT_NEAR(t.norm(), 1.0, 1e-9);
    EXPECT_GE(inliers, 15);
    // q = cam2_from_cam1 = R_2 R_1^T.
    const Eigen::Matrix3d R1 =
        gt.at(name1).cam_from_world.rotation.toRotationMatrix();
    const Eigen::Matrix3d R2 =
        gt.at(name2).cam_from_world.rotation.toRotationMatrix();
    errors.push_back(
        AngularDistanceDeg(QuaternionToRotation(q), R2 * R1.transpose()));
  }
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2,
                   errors.end());
  ::colmap_irav4::test::RecordFiguresF(
      "bundled example: median relative rotation error %.4f deg over %zu "
      "pairs\n",
      errors[errors.size() / 2], errors.size());
  EXPECT_LT(errors[errors.size() / 2], 0.5);
  // Dotted options reach the builder.
  const RunResult strict = RunCommand(
      dir, "view_graph --database_path '" + database + "' --output_path '" +
               output + "' --ViewGraph.min_num_inliers 1000");
  ASSERT_EQ(strict.exit_code, 0) << strict.err;
  EXPECT_LT(Lines(ReadText(output)).size(), 55u);
  EXPECT_GT(Lines(ReadText(output)).size(), 0u);
}

TEST(ViewGraphCommand, EmptyGraphIsReportedClearly) {
  COLMAP_IRAV4_REQUIRE_DATA("colmap_samples/t265_fisheye/database.db");
  TempDir dir;
  const std::string output = dir.File("relpose.txt");
  const RunResult result = RunCommand(
      dir, "view_graph --database_path '" + kDataDir +
               "/colmap_samples/t265_fisheye/database.db' --output_path '" +
               output + "'");
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("no verified image pair"), std::string::npos)
      << result.out;
  EXPECT_TRUE(std::filesystem::exists(output));
  EXPECT_TRUE(ReadText(output).empty());
}

// One line on stderr naming the file, non-zero exit, file unchanged.
void ExpectCleanFailure(const TempDir& dir, const std::string& database,
                        const std::string& problem) {
  SCOPED_TRACE(problem);
  const uint64_t hash = HashFile(database);
  const std::string output = dir.File("relpose.txt");
  const RunResult result =
      RunCommand(dir, "view_graph --database_path '" + database +
                          "' --output_path '" + output + "'");
  EXPECT_NE(result.exit_code, 0);
  EXPECT_TRUE(result.exit_code > 0 && result.exit_code < 128)
      << "crash? " << result.exit_code;
  const std::vector<std::string> lines = Lines(result.err);
  ASSERT_EQ(lines.size(), 1u) << result.err;
  ::colmap_irav4::test::RecordFiguresF("  exit %d, stderr: %s\n",
                                       result.exit_code, lines[0].c_str());
  EXPECT_NE(lines[0].find(database), std::string::npos);
  EXPECT_NE(lines[0].find(problem), std::string::npos);
  EXPECT_EQ(HashFile(database), hash);
  EXPECT_FALSE(std::filesystem::exists(output));
}

TEST(ViewGraphCommand, BadDatabasesFailCleanly) {
  TempDir dir;
  ExpectCleanFailure(dir, dir.File("missing.db"), "No such file");
  std::ofstream(dir.File("text.db")) << "just text\n";
  ExpectCleanFailure(dir, dir.File("text.db"), "not an SQLite database");
  const std::string no_table = dir.File("no_table.db");
  {
    test::SqliteWriter writer(no_table);
    writer.Exec(Colmap38Schema());
    writer.Exec("DROP TABLE keypoints;");
  }
  ExpectCleanFailure(dir, no_table, "table 'keypoints' is missing");
  const std::string bad_model = dir.File("bad_model.db");
  {
    test::SqliteWriter writer(bad_model);
    writer.Exec(Colmap38Schema());
    writer.Exec(
        "INSERT INTO cameras VALUES (1, 99, 640, 480, zeroblob(24), 0);");
  }
  ExpectCleanFailure(dir, bad_model, "unknown camera model id 99");
  const std::string bad_blob = dir.File("bad_blob.db");
  {
    test::SqliteWriter writer(bad_blob);
    writer.Exec(Colmap38Schema());
    // SIMPLE_PINHOLE f = 500, c = (320, 240): a valid camera.
    writer.Exec(
        "INSERT INTO cameras VALUES (1, 0, 640, 480, "
        "x'0000000000407F4000000000000074400000000000006E40', 0);");
    writer.Exec(
        "INSERT INTO images VALUES (1, 'a.jpg', 1, NULL, NULL, NULL, NULL, "
        "NULL, NULL, NULL);");
    writer.Exec("INSERT INTO keypoints VALUES (1, 10, 6, zeroblob(100));");
  }
  ExpectCleanFailure(dir, bad_blob,
                     "keypoints of image 1: data blob has 100 bytes");
  const std::string bad_camera = dir.File("bad_camera.db");
  {
    test::SqliteWriter writer(bad_camera);
    writer.Exec(Colmap38Schema());
    writer.Exec(
        "INSERT INTO cameras VALUES (1, 0, 640, 480, zeroblob(24), 0);");
    writer.Exec(
        "INSERT INTO images VALUES (1, 'a.jpg', 1, NULL, NULL, NULL, NULL, "
        "NULL, NULL, NULL);");
  }
  ExpectCleanFailure(
      dir, bad_camera,
      "camera 1 (SIMPLE_PINHOLE): focal length 0 is not positive");
  // A bad option is one clear line too.
  const RunResult result =
      RunCommand(dir,
                 "view_graph --database_path x --output_path y "
                 "--ViewGraph.drop_configs NOPE");
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_EQ(Lines(result.err).size(), 1u) << result.err;
  EXPECT_NE(result.err.find("--ViewGraph.drop_configs"), std::string::npos);
}

}  // namespace
}  // namespace colmap_irav4
