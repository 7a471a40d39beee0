#include "colmap_irav4/eval/onedsfm.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>

#include <gtest/gtest.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/util/error.h"
#include "tests/test_utils/data.h"
#include "tests/test_utils/record.h"
#include "tests/test_utils/temp_dir.h"

namespace colmap_irav4 {
namespace {

const std::string kMadrid = DataDir() + "/1dsfm/Madrid_Metropolis";

std::string TempPath(const std::string& name) {
  static const test::TempDir dir;  // removed when the test program exits
  return dir.File(name);
}

std::string WriteFile(const std::string& name, const std::string& text) {
  const std::string path = TempPath(name);
  std::ofstream(path) << text;
  return path;
}

// Cycle errors d(R_jk R_ij, R_ik) over all triangles i<j<k, sorted.
std::vector<double> TriangleCycleErrors(const std::vector<OneDsfmEdge>& edges) {
  std::map<std::pair<int, int>, Eigen::Matrix3d> rotation;  // R_ab, a->b
  std::map<int, std::vector<int>> neighbors;
  for (const OneDsfmEdge& e : edges) {
    rotation[{e.i, e.j}] = e.R_ij;
    rotation[{e.j, e.i}] = e.R_ij.transpose();
    neighbors[e.i].push_back(e.j);
    neighbors[e.j].push_back(e.i);
  }
  for (auto& [i, adjacent] : neighbors) {
    std::sort(adjacent.begin(), adjacent.end());
  }
  std::vector<double> errors;
  for (const auto& [i, adjacent_i] : neighbors) {
    for (int j : adjacent_i) {
      if (j <= i) continue;
      std::vector<int> common;  // k adjacent to both i and j
      std::set_intersection(adjacent_i.begin(), adjacent_i.end(),
                            neighbors[j].begin(), neighbors[j].end(),
                            std::back_inserter(common));
      for (int k : common) {
        if (k <= j) continue;
        errors.push_back(AngularDistanceDeg(rotation[{j, k}] * rotation[{i, j}],
                                            rotation[{i, k}]));
      }
    }
  }
  std::sort(errors.begin(), errors.end());
  return errors;
}

double Quantile(const std::vector<double>& sorted, double q) {
  return sorted[static_cast<size_t>(q * (sorted.size() - 1))];
}

double FractionBelow(const std::vector<double>& sorted, double value) {
  return static_cast<double>(
             std::lower_bound(sorted.begin(), sorted.end(), value) -
             sorted.begin()) /
         sorted.size();
}

TEST(OneDsfm, MadridRotationDirectionFromTripletCycles) {
  COLMAP_IRAV4_REQUIRE_DATA("1dsfm/Madrid_Metropolis");
  // With R_ij = R_j R_i^T every triangle of good edges closes:
  // R_jk R_ij = R_ik. The transposed reading closes only up to the
  // commutator of the relative rotations. Madrid's measured epipolar
  // geometries are very noisy (most triangles hold an outlier edge), so the
  // direction shows in the good triangles: the low quantiles and the
  // fraction that close within the paper's 3 deg.
  const std::string path = kMadrid + "/EGs.txt";
  const std::vector<OneDsfmEdge> converted = ReadOneDsfmEdges(path, 0);
  const std::vector<OneDsfmEdge> stored =
      ReadOneDsfmEdges(path, 0, OneDsfmRotation::kStored);
  ASSERT_EQ(converted.size(), 23784u);
  const std::vector<double> ours = TriangleCycleErrors(converted);
  const std::vector<double> transposed = TriangleCycleErrors(stored);
  ASSERT_EQ(ours.size(), transposed.size());
  EXPECT_GT(ours.size(), 1000000u);
  COLMAP_IRAV4_FIGURES << ours.size()
                       << " triangles, cycle error (deg) with R_ij = "
                       << "R_j R_i^T / with its transpose: median "
                       << Quantile(ours, 0.5) << " / "
                       << Quantile(transposed, 0.5) << ", 10% quantile "
                       << Quantile(ours, 0.1) << " / "
                       << Quantile(transposed, 0.1)
                       << ", fraction within 3 deg " << FractionBelow(ours, 3.0)
                       << " / " << FractionBelow(transposed, 3.0) << std::endl;
  EXPECT_LT(Quantile(ours, 0.5), Quantile(transposed, 0.5));
  EXPECT_LT(Quantile(ours, 0.1), 0.75 * Quantile(transposed, 0.1));
  EXPECT_GT(FractionBelow(ours, 3.0), 1.5 * FractionBelow(transposed, 3.0));
}

TEST(OneDsfm, MadridScene) {
  COLMAP_IRAV4_REQUIRE_DATA("1dsfm/Madrid_Metropolis");
  const OneDsfmScene scene = ReadOneDsfmScene(kMadrid);
  EXPECT_EQ(scene.graph.NumVertices(), 394);
  EXPECT_EQ(scene.graph.NumEdges(), 23784);  // all edges are inside cc.txt
  EXPECT_EQ(scene.graph.ConnectedComponents().size(), 1u);
  EXPECT_EQ(scene.graph.Name(0), "images/1022056833_b0bcddb09e_o.jpg");
  EXPECT_TRUE(scene.ground_truth.empty());  // no gt_bundle.out here
}

TEST(OneDsfm, BundlerCamerasLookDownMinusZ) {
  // A camera in OpenCV axes, points in front of it (positive depth).
  std::mt19937_64 rng(7);
  const Eigen::Matrix3d R_opencv = RandomRotation(&rng);
  const Eigen::Vector3d t_opencv(0.3, -0.2, 1.5);
  const Eigen::Matrix3d D = Eigen::Vector3d(1, -1, -1).asDiagonal();
  const Eigen::Matrix3d R_bundler = D * R_opencv;
  const Eigen::Vector3d t_bundler = D * t_opencv;
  std::vector<Eigen::Vector3d> points;
  for (const Eigen::Vector3d& cam_point :
       {Eigen::Vector3d(0.1, 0.2, 4.0), Eigen::Vector3d(-1, 0.5, 7.0)}) {
    points.push_back(R_opencv.transpose() * (cam_point - t_opencv));
    // Bundler's convention: a visible point has negative z in its camera.
    EXPECT_LT((R_bundler * points.back() + t_bundler).z(), 0);
  }
  std::ostringstream text;
  text.precision(17);
  text << "# Bundle file v0.3\n2 2\n";
  text << "1000 0.01 -0.02\n"
       << R_bundler << "\n"
       << t_bundler.transpose() << "\n";
  text << "0 0 0\n0 0 0\n0 0 0\n0 0 0\n0 0 0\n";  // not reconstructed
  for (const Eigen::Vector3d& X : points) {
    text << X.transpose() << "\n255 255 255\n1 0 3 1.5 -2.5\n";
  }
  const BundlerFile bundler = ReadBundlerFile(WriteFile("a.out", text.str()));
  ASSERT_EQ(bundler.cameras.size(), 2u);
  ASSERT_EQ(bundler.points.size(), 2u);
  EXPECT_TRUE(bundler.cameras[0].registered);
  EXPECT_FALSE(bundler.cameras[1].registered);
  EXPECT_DOUBLE_EQ(bundler.cameras[0].focal, 1000);
  EXPECT_LT(AngularDistanceDeg(bundler.cameras[0].R, R_opencv), 1e-6);
  EXPECT_LT((bundler.cameras[0].t - t_opencv).norm(), 1e-9);
  for (const BundlerPoint& point : bundler.points) {
    ASSERT_EQ(point.cameras, std::vector<int>({0}));
    const BundlerCamera& camera = bundler.cameras[0];
    EXPECT_GT((camera.R * point.xyz + camera.t).z(), 0);  // OpenCV: +z
  }
}

void ExpectInputError(const std::function<void()>& read,
                      const std::string& path, const std::string& fragment) {
  try {
    read();
    ADD_FAILURE() << "no InputError for " << path;
  } catch (const InputError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find(path), std::string::npos) << message;
    EXPECT_NE(message.find(fragment), std::string::npos) << message;
  }
}

TEST(OneDsfm, MalformedEdges) {
  const std::string good = "0 1 1 0 0 0 1 0 0 0 1 0 0 1\n";
  struct Case {
    std::string text;
    std::string fragment;
  };
  const std::vector<Case> cases = {
      {good + "1 2 1 0 0 0 1 0 0 0 1 0 0\n", "line 2: expected 14 fields"},
      {good + "1 2 1 0 0 0 1 x 0 0 1 0 0 1\n", "line 2: field 8 'x'"},
      {good + "1 2 1 0 0 0 2 0 0 0 1 0 0 1\n", "line 2: the 3x3 matrix is not"},
      {good + "1 2 1 0 0 0 -1 0 0 0 1 0 0 1\n", "line 2: the 3x3 matrix"},
      {good + "1 9 1 0 0 0 1 0 0 0 1 0 0 1\n", "line 2: index 9 out of range"},
      {good + "-1 2 1 0 0 0 1 0 0 0 1 0 0 1\n", "line 2: index -1"},
      {"", "no edges"},
  };
  for (size_t k = 0; k < cases.size(); ++k) {
    const std::string path =
        WriteFile("EGs_" + std::to_string(k) + ".txt", cases[k].text);
    ExpectInputError([&] { ReadOneDsfmEdges(path, 5); }, path,
                     cases[k].fragment);
  }
  ExpectInputError([] { ReadOneDsfmEdges("/nonexistent/EGs.txt"); },
                   "/nonexistent/EGs.txt", "cannot open");
}

TEST(OneDsfm, MalformedComponentAndBundler) {
  const std::string cc = WriteFile("cc.txt", "0\n1\n7\n");
  ExpectInputError([&] { ReadOneDsfmComponent(cc, 5); }, cc,
                   "line 3: index 7 out of range");
  const std::string empty_cc = WriteFile("empty_cc.txt", "\n");
  ExpectInputError([&] { ReadOneDsfmComponent(empty_cc, 5); }, empty_cc,
                   "no image indices");
  const std::string bad_rotation =
      WriteFile("bad.out",
                "# Bundle file v0.3\n1 0\n1 0 0\n1 0 0\n0 1 0\n1 0 0\n0 0 0\n");
  ExpectInputError([&] { ReadBundlerFile(bad_rotation); }, bad_rotation,
                   "line 4: the 3x3 matrix is not a rotation");
  const std::string truncated =
      WriteFile("truncated.out", "# Bundle file v0.3\n1 0\n1 0 0\n1 0 0\n");
  ExpectInputError([&] { ReadBundlerFile(truncated); }, truncated,
                   "unexpected end of file");
  // Ends right after a camera's intrinsics (found by the fuzzer: read past
  // the last line).
  const std::string no_rotation =
      WriteFile("no_rotation.out", "# Bundle file v0.3\n2 1\n500 0 0.5\n");
  ExpectInputError([&] { ReadBundlerFile(no_rotation); }, no_rotation,
                   "unexpected end of file");
  // A view count whose field count overflows an int.
  const std::string many_views =
      WriteFile("many_views.out",
                "# Bundle file v0.3\n1 1\n500 0 0\n1 0 0\n0 1 0\n0 0 1\n0 0 0\n"
                "1 2 3\n255 0 0\n1999999999 0 3 4.5 6.5\n");
  ExpectInputError([&] { ReadBundlerFile(many_views); }, many_views,
                   "1999999999 views need 7999999997 fields, found 5");
  const std::string empty = WriteFile("empty.out", "");
  ExpectInputError([&] { ReadBundlerFile(empty); }, empty, "empty file");
}

}  // namespace
}  // namespace colmap_irav4
