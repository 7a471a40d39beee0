#include "colmap_irav4/eval/relpose_io.h"

#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/util/error.h"
#include "tests/test_utils/temp_dir.h"

namespace colmap_irav4 {
namespace {

std::string WriteFile(const std::string& name, const std::string& text) {
  static const test::TempDir dir;  // removed when the test program exits
  const std::string path = dir.File(name);
  std::ofstream(path) << text;
  return path;
}

TEST(RelposeIo, ReadsPairsInOurConvention) {
  std::mt19937_64 rng(3);
  const Eigen::Matrix3d R_a = RandomRotation(&rng), R_b = RandomRotation(&rng);
  const Eigen::Vector4d q = RotationToQuaternion(R_b * R_a.transpose());
  std::ostringstream text;
  text.precision(17);
  text << "# comment\na.jpg b.jpg " << q.transpose() << " 0 0 1 57\n"
       << "b.jpg c.jpg 1 0 0 0 1 0 0\n"
       << "b.jpg a.jpg " << -q(0) << " " << q(1) << " " << q(2) << " " << q(3)
       << " 1 0 0 3\n";  // repeated pair (same rotation): ignored
  const RotationGraph graph =
      ReadRelativePoses(WriteFile("ok.txt", text.str()));
  ASSERT_EQ(graph.NumVertices(), 3);
  ASSERT_EQ(graph.NumEdges(), 2);
  EXPECT_EQ(graph.Name(0), "a.jpg");
  EXPECT_EQ(graph.Name(2), "c.jpg");
  EXPECT_EQ(graph.Edge(0).i, 0);
  EXPECT_EQ(graph.Edge(0).j, 1);
  EXPECT_LT(AngularDistanceDeg(graph.Edge(0).R_ij, R_b * R_a.transpose()),
            1e-9);
  EXPECT_EQ(graph.Edge(0).weight, 57);
  EXPECT_EQ(graph.Edge(1).weight, 1);
}

TEST(RelposeIo, WriteReadRoundTrip) {
  std::mt19937_64 rng(4);
  const std::vector<std::string> names = {"x.jpg", "y.jpg", "z.jpg"};
  const std::vector<Eigen::Matrix3d> rotations = {
      RandomRotation(&rng), RandomRotation(&rng), RandomRotation(&rng)};
  const std::string path = WriteFile("rotations.txt", "");
  WriteAbsoluteRotations(path, names, rotations, {true, false, true});
  const auto read = ReadAbsoluteRotations(path);
  ASSERT_EQ(read.size(), 2u);
  EXPECT_EQ(read[0].first, "x.jpg");
  EXPECT_EQ(read[1].first, "z.jpg");
  EXPECT_LT(AngularDistanceDeg(read[0].second, rotations[0]), 1e-9);
  EXPECT_LT(AngularDistanceDeg(read[1].second, rotations[2]), 1e-9);
  // A directory that cannot be created (a file is in the way).
  EXPECT_THROW(WriteAbsoluteRotations(path + "/dir/r.txt", names, rotations,
                                      {true, true, true}),
               InputError);
}

TEST(RelposeIo, MalformedInputNamesFileAndLine) {
  const std::string good = "a b 1 0 0 0 1 0 0 10\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {good + "a c 1 0 0 0 1 0\n", "line 2: expected 9 to 10 fields, found 8"},
      {good + "a c 1 0 0 0 1 0 0 10 11\n", "line 2: expected 9 to 10"},
      {good + "a c 1 0 zero 0 1 0 0\n", "line 2: field 5 'zero'"},
      {good + "a c 1 0 0 0 1 0 nan\n", "line 2: field 9 'nan'"},
      {good + "a c 2 0 0 0 1 0 0\n", "line 2: quaternion norm 2"},
      {good + "a c 0 0 0 0 1 0 0\n", "line 2: quaternion norm 0"},
      {good + "a c 1 0 0 0 1 0 0 -3\n", "line 2: inlier count -3 is negative"},
      {good + "b a 0 1 0 0 1 0 0\n",
       "line 2: pair 'b' 'a' repeated with a rotation 180"},
      {"c c 1 0 0 0 1 0 0\n", "no image pairs"},  // self-pair skipped
      {"# only a comment\n\n", "no image pairs"},
  };
  for (size_t k = 0; k < cases.size(); ++k) {
    const std::string path =
        WriteFile("bad_" + std::to_string(k) + ".txt", cases[k].first);
    try {
      ReadRelativePoses(path);
      ADD_FAILURE() << "no InputError for case " << k;
    } catch (const InputError& error) {
      const std::string message = error.what();
      EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
      EXPECT_NE(message.find(cases[k].second), std::string::npos) << message;
    }
  }
  EXPECT_THROW(
      ReadAbsoluteRotations(WriteFile("dup.txt", "a 1 0 0 0\na 1 0 0 0\n")),
      InputError);
  EXPECT_THROW(ReadAbsoluteRotations(WriteFile("cols.txt", "a 1 0 0\n")),
               InputError);
}

}  // namespace
}  // namespace colmap_irav4
