// End-to-end tests of `colmap_irav4 rotation_averager` through the binary.

#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/relpose_io.h"
#include "colmap_irav4/eval/rotation_eval.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/rotation_averaging/synthetic.h"
#include "colmap_irav4/util/random.h"
#include "tests/test_utils/data.h"
#include "tests/test_utils/rotation_test_utils.h"
#include "tests/test_utils/temp_dir.h"

namespace colmap_irav4 {
namespace {

namespace fs = std::filesystem;

// One directory for the test program's files, removed when it exits.
const fs::path& TempDir() {
  static const test::TempDir dir;
  static const fs::path path = dir.path();
  return path;
}

std::string WriteFile(const std::string& name, const std::string& text) {
  const std::string path = (TempDir() / name).string();
  std::ofstream(path) << text;
  return path;
}

std::string ReadFile(const std::string& path) {
  std::ifstream file(path);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

struct CommandRun {
  int exit_code = -1;  // -1: killed by a signal (a crash)
  std::string out;
  std::string err;
};

CommandRun RunCommand(const std::string& arguments) {
  const std::string out = (TempDir() / "stdout.txt").string();
  const std::string err = (TempDir() / "stderr.txt").string();
  const std::string command = std::string(COLMAP_IRAV4_BINARY) +
                              " rotation_averager " + arguments + " >" + out +
                              " 2>" + err;
  const int status = std::system(command.c_str());
  CommandRun run;
  if (WIFEXITED(status)) run.exit_code = WEXITSTATUS(status);
  run.out = ReadFile(out);
  run.err = ReadFile(err);
  return run;
}

// Writes a synthetic scene as a relative pose file and its ground truth.
void WriteScene(const SyntheticProblem& problem, const std::string& relpose,
                const std::string& gt) {
  std::ofstream file(relpose);
  file.precision(17);
  for (const RelativeRotation& e : problem.graph.Edges()) {
    const Eigen::Vector4d q = RotationToQuaternion(e.R_ij);
    file << "img" << e.i << ".jpg img" << e.j << ".jpg " << q.transpose()
         << " 0 0 1 100\n";
  }
  std::vector<std::string> names;
  for (int v = 0; v < problem.graph.NumVertices(); ++v) {
    names.push_back("img" + std::to_string(v) + ".jpg");
  }
  WriteAbsoluteRotations(gt, names, problem.ground_truth,
                         std::vector<bool>(names.size(), true));
}

using test::MakeRandomProblem;

double ErrorAgainst(const std::string& output, const std::string& gt) {
  std::map<std::string, Eigen::Matrix3d> estimate, truth;
  for (auto& [name, R] : ReadAbsoluteRotations(output)) estimate[name] = R;
  for (auto& [name, R] : ReadAbsoluteRotations(gt)) truth[name] = R;
  return EvaluateRotations(estimate, truth).median_deg;
}

TEST(RotationAveragerCommand, SyntheticRelativePosesEveryMethod) {
  const SyntheticProblem problem = MakeRandomProblem(100, 1500, 3.0, 0.2, 11);
  const std::string relpose = (TempDir() / "relpose.txt").string();
  const std::string gt = (TempDir() / "gt.txt").string();
  WriteScene(problem, relpose, gt);
  std::map<std::string, double> median;
  for (const std::string method :
       {"spanning_tree", "l1_irls", "ira", "irav4"}) {
    const std::string output = (TempDir() / (method + ".txt")).string();
    const CommandRun run =
        RunCommand("--relpose_path " + relpose + " --method " + method +
                   " --output_path " + output + " --gt_path " + gt);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_NE(run.out.find("Rotation errors vs " + gt + ": 100 cameras"),
              std::string::npos)
        << run.out;
    EXPECT_EQ(ReadAbsoluteRotations(output).size(), 100u);
    median[method] = ErrorAgainst(output, gt);
  }
  for (const std::string method : {"l1_irls", "ira", "irav4"}) {
    EXPECT_LT(median[method], 1.5) << method;
    EXPECT_LT(5 * median[method], median["spanning_tree"]) << method;
  }
}

TEST(RotationAveragerCommand, SummaryJsonPerMethod) {
  const SyntheticProblem problem = MakeRandomProblem(80, 900, 3.0, 0.2, 5);
  const std::string relpose = (TempDir() / "relpose_summary.txt").string();
  const std::string gt = (TempDir() / "gt_summary.txt").string();
  WriteScene(problem, relpose, gt);
  for (const std::string method : {"irav4", "l1_irls"}) {
    const std::string summary = (TempDir() / (method + ".json")).string();
    const CommandRun run =
        RunCommand("--relpose_path " + relpose + " --method " + method +
                   " --gt_path " + gt + " --summary_path " + summary);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_NE(run.out.find("cameras > 30 deg off"), std::string::npos)
        << run.out;
    const std::string json = ReadFile(summary);
    EXPECT_NE(json.find("\"method\": \"" + method + "\""), std::string::npos)
        << json;
    EXPECT_NE(json.find("\"num_cameras_estimated\": 80"), std::string::npos)
        << json;
    EXPECT_NE(json.find("\"num_edges\": 900"), std::string::npos) << json;
    EXPECT_NE(json.find("\"stage_seconds\": {\""), std::string::npos) << json;
    if (method == "irav4") {
      // A reference and at least one cluster, whose sizes add up to 80.
      EXPECT_EQ(json.find("\"reference_size\": 0,"), std::string::npos) << json;
      const size_t open = json.find("\"cluster_sizes\": [");
      ASSERT_NE(open, std::string::npos) << json;
      std::stringstream sizes(json.substr(open + 18));
      int total = 0, size = 0;
      char separator = 0;
      while (sizes >> size) {
        total += size;
        sizes >> separator;
        if (separator == ']') break;
      }
      EXPECT_EQ(total, 80) << json;
    } else {
      EXPECT_NE(json.find("\"reference_size\": 0,"), std::string::npos) << json;
      EXPECT_NE(json.find("\"cluster_sizes\": []"), std::string::npos) << json;
    }
  }
}

TEST(RotationAveragerCommand, MadridEgPath) {
  COLMAP_IRAV4_REQUIRE_DATA("1dsfm/Madrid_Metropolis");
  const std::string output = (TempDir() / "madrid.txt").string();
  const CommandRun run = RunCommand(
      "--eg_path " + DataDir() +
      "/1dsfm/Madrid_Metropolis --method l1_irls --output_path " + output);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("Estimated 394 of 394 rotations"), std::string::npos);
  EXPECT_EQ(ReadAbsoluteRotations(output).size(), 394u);
}

TEST(RotationAveragerCommand, StrechaDatabaseAgainstGtCameras) {
  COLMAP_IRAV4_REQUIRE_DATA("strecha/fountain-P11");
  // The real path: COLMAP database -> view graph -> rotations, evaluated
  // against the LIDAR ground truth directory.
  const std::string scene = DataDir() + "/strecha/fountain-P11";
  for (const std::string method :
       {"irav4", "ira", "l1_irls", "spanning_tree"}) {
    const std::string output =
        (TempDir() / ("fountain_" + method + ".txt")).string();
    const CommandRun run = RunCommand(
        "--database_path " + scene + "/database.db --method " + method +
        " --gt_path " + scene + "/gt_cameras --output_path " + output);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_EQ(ReadAbsoluteRotations(output).size(), 11u);
    const size_t at = run.out.find("11 cameras, median ");
    ASSERT_NE(at, std::string::npos) << run.out;
    const double median = std::stod(run.out.substr(at + 19));
    EXPECT_LT(median, 0.5) << method;
  }
}

TEST(RotationAveragerCommand, OneDsfmDirectoryWithBundlerGroundTruth) {
  // A 1DSfM scene written in the dataset's conventions (Bundler axes,
  // EGs rotation R_i R_j^T, translation = camera j's centre in camera i's
  // frame) from known cameras: the readers' conversions must agree with each
  // other, so the estimate matches gt_bundle.out exactly.
  const int num_images = 30;
  std::mt19937_64 rng(21);
  const Eigen::Matrix3d D = Eigen::Vector3d(1, -1, -1).asDiagonal();
  std::vector<Eigen::Matrix3d> R_bundler;
  std::vector<Eigen::Vector3d> centers;
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int k = 0; k < num_images; ++k) {
    R_bundler.push_back(D * RandomRotation(&rng));
    centers.push_back(RandomVector<3>(normal, rng));
  }
  const fs::path dir = TempDir() / "onedsfm_scene";
  fs::create_directories(dir);
  std::ofstream list(dir / "list.txt"), cc(dir / "cc.txt"),
      egs(dir / "EGs.txt"), bundle(dir / "gt_bundle.out");
  egs.precision(17);
  bundle.precision(17);
  bundle << "# Bundle file v0.3\n" << num_images << " 0\n";
  for (int k = 0; k < num_images; ++k) {
    list << "images/" << k << ".jpg 0 1000\n";
    if (k != 5) cc << k << "\n";  // image 5 is outside the component
    if (k == 7) {                 // not reconstructed by Bundler
      bundle << "0 0 0\n0 0 0\n0 0 0\n0 0 0\n0 0 0\n";
    } else {
      bundle << "1000 0 0\n"
             << R_bundler[k] << "\n"
             << (-R_bundler[k] * centers[k]).transpose() << "\n";
    }
    for (int j = k + 1; j < num_images; j += 1 + k % 3) {
      const Eigen::Matrix3d M = R_bundler[k] * R_bundler[j].transpose();
      const Eigen::Vector3d direction =
          (R_bundler[k] * (centers[j] - centers[k])).normalized();
      egs << k << ' ' << j;
      for (int e = 0; e < 9; ++e) egs << ' ' << M(e / 3, e % 3);
      egs << ' ' << direction.transpose() << "\n";
    }
  }
  list.close();
  cc.close();
  egs.close();
  bundle.close();
  const CommandRun run =
      RunCommand("--eg_path " + dir.string() + " --method l1_irls");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("Estimated 29 of 29 rotations"), std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("gt_bundle.out: 28 cameras, median 0.000 deg, mean "
                         "0.000 deg, max 0.000 deg"),
            std::string::npos)
      << run.out;
}

TEST(RotationAveragerCommand, DisconnectedGraphWarnsAndKeepsLargest) {
  const std::string relpose = WriteFile(
      "disconnected.txt",
      "a b 1 0 0 0 1 0 0 50\nb c 1 0 0 0 1 0 0 50\nc a 1 0 0 0 1 0 0 50\n"
      "x y 1 0 0 0 1 0 0 50\n");
  const std::string output = (TempDir() / "disconnected_out.txt").string();
  const CommandRun run =
      RunCommand("--relpose_path " + relpose +
                 " --method spanning_tree --output_path " + output);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("2 connected components; estimating the largest (3 "
                         "of 5 images)"),
            std::string::npos)
      << run.err;
  const auto rotations = ReadAbsoluteRotations(output);
  ASSERT_EQ(rotations.size(), 3u);
  for (const auto& [name, R] : rotations) {
    EXPECT_TRUE(name == "a" || name == "b" || name == "c") << name;
  }
}

TEST(RotationAveragerCommand, UnknownImageInGroundTruthWarns) {
  const std::string relpose =
      WriteFile("small.txt", "a b 1 0 0 0 1 0 0 50\nb c 1 0 0 0 1 0 0 50\n");
  const std::string gt = WriteFile(
      "small_gt.txt", "a 1 0 0 0\nb 1 0 0 0\nc 1 0 0 0\nzz 1 0 0 0\n");
  const CommandRun run = RunCommand("--relpose_path " + relpose +
                                    " --method l1_irls --gt_path " + gt);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("1 images not estimated or not in the graph (e.g. "
                         "'zz')"),
            std::string::npos)
      << run.err;
  EXPECT_NE(run.out.find(": 3 cameras, median 0.000 deg"), std::string::npos)
      << run.out;
  // No common image at all: a clear error.
  const std::string other = WriteFile("other_gt.txt", "zz 1 0 0 0\n");
  const CommandRun none = RunCommand("--relpose_path " + relpose +
                                     " --method l1_irls --gt_path " + other);
  EXPECT_EQ(none.exit_code, 1);
  EXPECT_NE(none.err.find(other + ": no image in common"), std::string::npos)
      << none.err;
}

TEST(RotationAveragerCommand, MalformedInputGivesOneLineError) {
  const std::string good = "a b 1 0 0 0 1 0 0 50\n";
  struct Case {
    std::string file;
    std::string text;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {"columns.txt", good + "b c 1 0 0 0 1 0\n", "line 2: expected 9 to 10"},
      {"numeric.txt", good + "b c 1 0 0 0 1 0 zero\n", "line 2: field 9"},
      {"rotation.txt", good + "b c 3 0 0 0 1 0 0\n", "line 2: quaternion norm"},
      {"empty.txt", "", "no image pairs"},
  };
  for (const Case& c : cases) {
    const std::string path = WriteFile(c.file, c.text);
    const std::string output = (TempDir() / ("out_" + c.file)).string();
    const CommandRun run =
        RunCommand("--relpose_path " + path + " --output_path " + output);
    EXPECT_EQ(run.exit_code, 1) << c.file << ": " << run.err;
    EXPECT_NE(run.err.find("ERROR: " + path + ": " + c.expected),
              std::string::npos)
        << run.err;
    EXPECT_FALSE(fs::exists(output)) << c.file;
  }
  // Malformed 1DSfM directory and ground truth.
  const fs::path eg_dir = TempDir() / "eg";
  fs::create_directories(eg_dir);
  std::ofstream(eg_dir / "EGs.txt") << "0 1 1 0 0 0 1 0 0 0 2 0 0 1\n";
  CommandRun run = RunCommand("--eg_path " + eg_dir.string());
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("EGs.txt: line 1: the 3x3 matrix is not a rotation"),
            std::string::npos)
      << run.err;
  const std::string relpose = WriteFile("ok.txt", good);
  const std::string gt = WriteFile("bad_gt.txt", "a 1 0 0\n");
  run = RunCommand("--relpose_path " + relpose + " --gt_path " + gt);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find(gt + ": line 1: expected 5 fields"), std::string::npos)
      << run.err;
  // Bad options.
  run = RunCommand("--relpose_path " + relpose + " --method nope");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("--method: unknown method 'nope'"), std::string::npos);
  run =
      RunCommand("--relpose_path " + relpose + " --eg_path " + eg_dir.string());
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("exactly one of"), std::string::npos);
  // The rest needs the shared data (the checks above have run).
  COLMAP_IRAV4_REQUIRE_DATA("colmap_samples/t265_fisheye/database.db");
  run = RunCommand("--database_path " + DataDir() +
                   "/colmap_samples/t265_fisheye/database.db");  // no pairs
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("t265_fisheye/database.db: the graph has no edges"),
            std::string::npos)
      << run.err;
  run = RunCommand("--database_path /nonexistent/db.db");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("/nonexistent/db.db"), std::string::npos) << run.err;
  run = RunCommand("--relpose_path " + relpose +
                   " --RotationAveraging.linear_solver qr");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("--RotationAveraging.linear_solver"),
            std::string::npos);
  run = RunCommand("--relpose_path /nonexistent/relpose.txt");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("/nonexistent/relpose.txt: cannot open"),
            std::string::npos);
}

}  // namespace
}  // namespace colmap_irav4
