// Hostile inputs end to end (issue 10): every case gives a clear error naming
// the file and the record (exit 1) or a warning and a correct result (exit 0);
// never an abort, never exit 0 with a wrong model. The database is never
// written, and OUT/0 is always a complete old model, a complete new one, or
// absent. Each test prints one "CASE |" line (the table of the note).

#include <signal.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <random>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "colmap_irav4/io/database_writer.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "tests/test_utils/database_test_utils.h"

namespace colmap_irav4 {
namespace {

namespace fs = std::filesystem;
using test::CopyExampleDatabase;
using test::HashFile;
using test::ReadText;
using test::RunResult;
using test::SqliteWriter;
using test::TempDir;

constexpr int64_t kPairFactor = 2147483647;

RunResult RunProgram(const std::string& arguments, const TempDir& temp) {
  return test::RunShell(std::string(COLMAP_IRAV4_BINARY) + " " + arguments,
                        temp);
}

// "complete new" / "complete old" / "absent" / "damaged" of OUT/0, given
// the number of images of the old model (0: there was none).
std::string ModelState(const std::string& model, size_t old_num_images,
                       const std::string& old_marker_image = "") {
  if (!fs::exists(model)) return "absent";
  try {
    const Reconstruction reconstruction = ReadReconstruction(model);
    if (old_num_images > 0 && reconstruction.images.size() == old_num_images &&
        !old_marker_image.empty()) {
      for (const auto& [id, image] : reconstruction.images) {
        if (image.name == old_marker_image) return "complete old";
      }
    }
    return "complete new";
  } catch (const std::exception& error) {
    return std::string("damaged: ") + error.what();
  }
}

// The first line of the output holding `needle` (for the table).
std::string LineWith(const std::string& output, const std::string& needle) {
  const size_t at = output.find(needle);
  if (at == std::string::npos) return "(not found: " + needle + ")";
  const size_t begin = output.rfind('\n', at) + 1;
  const size_t end = output.find('\n', at);
  std::string line = output.substr(begin, end - begin);
  // Drop glog's prefix.
  const size_t bracket = line.find("] ");
  if (line.size() > 1 && (line[0] == 'W' || line[0] == 'I' || line[0] == 'E') &&
      bracket != std::string::npos) {
    line = line.substr(bracket + 2);
  }
  return line;
}

void PrintCase(const std::string& name, const std::string& says, int exit_code,
               bool hash_unchanged, const std::string& output_state) {
  std::cout << "CASE | " << name << " | " << says << " | " << exit_code << " | "
            << (hash_unchanged ? "yes" : "NO") << " | " << output_state
            << std::endl;
}

// A small model: one 100 x 100 SIMPLE_PINHOLE camera (focal `focal`), the
// images of `names`.
Reconstruction SmallModel(const std::vector<std::string>& names,
                          double focal = 100) {
  Reconstruction reconstruction;
  Camera camera;
  camera.camera_id = 1;
  camera.model_id = 0;
  camera.width = 100;
  camera.height = 100;
  camera.params = {focal, 50, 50};
  reconstruction.cameras[1] = camera;
  for (size_t k = 0; k < names.size(); ++k) {
    Image image;
    image.image_id = static_cast<image_t>(k + 1);
    image.camera_id = 1;
    image.name = names[k];
    reconstruction.images[image.image_id] = image;
  }
  return reconstruction;
}

// A small old model at OUT/0 (one image named "old_marker.jpg") so that
// "complete old" is recognisable.
void WriteOldModel(const std::string& model) {
  WriteReconstruction(SmallModel({"old_marker.jpg"}), model, "BIN");
}

struct Case {
  TempDir temp;
  std::string database;
  std::string sparse;
  uint64_t hash = 0;
  Case() : database(CopyExampleDatabase(temp)), sparse(temp.File("sparse")) {}
  void Freeze() { hash = HashFile(database); }
  RunResult Map(const std::string& extra = "") {
    return RunProgram("mapper --database_path " + database + " --output_path " +
                          sparse + " --Mapper.num_threads 2 " + extra,
                      temp);
  }
  bool Unchanged() const {
    return HashFile(database) == hash && !fs::exists(database + "-wal") &&
           !fs::exists(database + "-shm") && !fs::exists(database + "-journal");
  }
};

TEST(Reliability, SelfPairIsSkippedWithAWarning) {
  Case c;
  {
    SqliteWriter writer(c.database);
    writer.Exec("INSERT INTO two_view_geometries SELECT " +
                std::to_string(kPairFactor * 3 + 3) +
                ", rows, cols, data, config, F, E, H, qvec, tvec FROM "
                "two_view_geometries WHERE pair_id = " +
                std::to_string(kPairFactor * 1 + 2) + ";");
  }
  c.Freeze();
  const RunResult run = c.Map();
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("paired with itself, skipped"), std::string::npos)
      << run.output;
  EXPECT_TRUE(c.Unchanged());
  EXPECT_EQ(ReadReconstruction(c.sparse + "/0").images.size(), 11u);
  PrintCase("self-pair (3,3) in two_view_geometries",
            LineWith(run.output, "paired with itself"), run.exit_code,
            c.Unchanged(), ModelState(c.sparse + "/0", 0));
}

TEST(Reliability, InvalidCamerasAreRejectedOrReset) {
  struct Variant {
    std::string name;
    int model;
    std::vector<double> params;
    std::string expected;
  };
  const std::vector<Variant> variants = {
      {"negative focal", 1, {-999.8, -999.8, 1536, 1024}, "is not positive"},
      {"zero focal", 1, {0, 0, 1536, 1024}, "is not positive"},
      {"NaN focal", 1, {NAN, 2760, 1536, 1024}, "is not finite"},
      {"NaN principal point", 1, {2760, 2760, NAN, 1024}, "is not finite"},
      {"SIMPLE_RADIAL k = 1e6", 2, {2760, 1536, 1024, 1e6}, "distortion"},
      {"SIMPLE_RADIAL k = -5", 2, {2760, 1536, 1024, -5}, "distortion"},
  };
  for (const Variant& variant : variants) {
    Case c;
    {
      SqliteWriter writer(c.database);
      writer.Run("UPDATE cameras SET model = ?, params = ? WHERE camera_id = 1",
                 {variant.model, test::ToBlob(variant.params)});
    }
    c.Freeze();
    const RunResult run = c.Map();
    EXPECT_EQ(run.exit_code, 1) << variant.name << run.output;
    EXPECT_NE(run.output.find("ERROR: " + c.database + ": camera 1"),
              std::string::npos)
        << run.output;
    EXPECT_NE(run.output.find(variant.expected), std::string::npos)
        << run.output;
    EXPECT_TRUE(c.Unchanged());
    EXPECT_FALSE(fs::exists(c.sparse + "/0"));
    PrintCase("camera: " + variant.name, LineWith(run.output, "ERROR"),
              run.exit_code, c.Unchanged(), ModelState(c.sparse + "/0", 0));
    if (variant.name == "negative focal") {
      // With the flag: started from a default focal, refined, a model.
      const RunResult reset = c.Map("--Mapper.reset_invalid_cameras 1");
      EXPECT_EQ(reset.exit_code, 0) << reset.output;
      EXPECT_NE(reset.output.find("reset to focal"), std::string::npos);
      const Reconstruction model = ReadReconstruction(c.sparse + "/0");
      EXPECT_GT(model.cameras.at(1).params[0], 0);
      PrintCase("camera: negative focal, --Mapper.reset_invalid_cameras 1",
                LineWith(reset.output, "reset to focal"), reset.exit_code,
                c.Unchanged(), ModelState(c.sparse + "/0", 0));
    }
  }
}

TEST(Reliability, ZeroUsablePairsSaysWhatWasDroppedAndWhy) {
  Case c;
  {
    SqliteWriter writer(c.database);
    writer.Exec("UPDATE two_view_geometries SET config = 42;");
  }
  c.Freeze();
  RunResult run = c.Map();
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.output.find("dropped: 55 unknown config"), std::string::npos)
      << run.output;
  PrintCase("every pair with config 42", LineWith(run.output, "ERROR"),
            run.exit_code, c.Unchanged(), ModelState(c.sparse + "/0", 0));
  Case d;
  d.Freeze();
  run = d.Map(
      "--ViewGraph.drop_configs CALIBRATED,UNCALIBRATED,PLANAR_OR_PANORAMIC");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.output.find("config CALIBRATED"), std::string::npos)
      << run.output;
  EXPECT_EQ(run.output.find("run a matcher"), std::string::npos) << run.output;
  PrintCase("every pair dropped by --ViewGraph.drop_configs",
            LineWith(run.output, "ERROR"), run.exit_code, d.Unchanged(),
            ModelState(d.sparse + "/0", 0));
}

TEST(Reliability, NonFiniteAndOutOfImageKeypointsAreDroppedAndCounted) {
  Case c;
  int rows5 = 0;
  {
    // Image 5: its first 60 keypoints NaN; image 6: 40 outside the image.
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(c.database.c_str(), &db), SQLITE_OK);
    for (const int image_id : {5, 6}) {
      sqlite3_stmt* stmt = nullptr;
      sqlite3_prepare_v2(db,
                         "SELECT rows, cols, data FROM keypoints WHERE "
                         "image_id = ?",
                         -1, &stmt, nullptr);
      sqlite3_bind_int(stmt, 1, image_id);
      ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
      const int rows = sqlite3_column_int(stmt, 0);
      const int cols = sqlite3_column_int(stmt, 1);
      if (image_id == 5) rows5 = rows;
      std::vector<float> data(static_cast<size_t>(rows) * cols);
      std::memcpy(data.data(), sqlite3_column_blob(stmt, 2),
                  data.size() * sizeof(float));
      sqlite3_finalize(stmt);
      for (int k = 0; k < 60 && k < rows; ++k) {
        if (image_id == 5) {
          data[k * cols] = NAN;
        } else if (k < 40) {
          data[k * cols + 1] = 1e7f;
        }
      }
      sqlite3_prepare_v2(db, "UPDATE keypoints SET data = ? WHERE image_id = ?",
                         -1, &stmt, nullptr);
      sqlite3_bind_blob(stmt, 1, data.data(),
                        static_cast<int>(data.size() * sizeof(float)),
                        SQLITE_TRANSIENT);
      sqlite3_bind_int(stmt, 2, image_id);
      ASSERT_EQ(sqlite3_step(stmt), SQLITE_DONE);
      sqlite3_finalize(stmt);
    }
    sqlite3_close(db);
  }
  c.Freeze();
  const RunResult run = c.Map();
  EXPECT_EQ(run.exit_code, 0) << run.output;
  const std::string summary = ReadText(c.sparse + "/summary.json");
  EXPECT_NE(summary.find("\"non-finite keypoints dropped\": 60"),
            std::string::npos)
      << summary;
  EXPECT_NE(summary.find("\"keypoint outside the images dropped\": 40"),
            std::string::npos)
      << summary;
  // Issue 28, item 8: the NaN keypoints are no 2D points of the model (the
  // reader refuses any NaN), and the summary says so.
  const Reconstruction model = ReadReconstruction(c.sparse + "/0");
  EXPECT_EQ(model.images.size(), 11u);
  EXPECT_EQ(model.images.at(5).points2D.size() + 60,
            static_cast<size_t>(rows5));
  for (const Point2D& point2D : model.images.at(5).points2D) {
    ASSERT_TRUE(point2D.xy.allFinite());
  }
  EXPECT_NE(summary.find("60 non-finite keypoints left out"), std::string::npos)
      << summary;
  PrintCase("60 NaN keypoints (image 5), 40 outside (image 6)",
            LineWith(run.output, "database:"), run.exit_code, c.Unchanged(),
            ModelState(c.sparse + "/0", 0));
}

TEST(Reliability, PairIdsOutOfRangeAndBothOrders) {
  Case c;
  {
    SqliteWriter writer(c.database);
    writer.Exec("INSERT INTO two_view_geometries SELECT " +
                std::to_string((int64_t{1} << 32) * kPairFactor + 2) +
                ", rows, cols, data, config, F, E, H, qvec, tvec FROM "
                "two_view_geometries WHERE pair_id = " +
                std::to_string(kPairFactor * 1 + 2) + ";");
  }
  c.Freeze();
  RunResult run = c.Map();
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.output.find("first image id 4294967296 is out of range"),
            std::string::npos)
      << run.output;
  PrintCase("pair_id with first image id 2^32", LineWith(run.output, "ERROR"),
            run.exit_code, c.Unchanged(), ModelState(c.sparse + "/0", 0));

  Case d;
  {
    // (2, 1) stored as well as (1, 2); (4, 3) stored only swapped.
    SqliteWriter writer(d.database);
    writer.Exec("INSERT INTO two_view_geometries SELECT " +
                std::to_string(kPairFactor * 2 + 1) +
                ", rows, cols, data, config, F, E, H, qvec, tvec FROM "
                "two_view_geometries WHERE pair_id = " +
                std::to_string(kPairFactor * 1 + 2) + ";");
  }
  d.Freeze();
  run = d.Map();
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("stored in both orders"), std::string::npos);
  PrintCase("pair stored as (1,2) and (2,1)",
            LineWith(run.output, "both orders"), run.exit_code, d.Unchanged(),
            ModelState(d.sparse + "/0", 0));
}

TEST(Reliability, ImageNamesTxtCannotHoldFailBeforeWork) {
  for (const std::string& name : {std::string("a\nb.jpg"), std::string("")}) {
    Case c;
    {
      SqliteWriter writer(c.database);
      writer.Exec("UPDATE images SET name = '" + name +
                  "' WHERE image_id = 4;");
    }
    c.Freeze();
    const RunResult run = c.Map("--output_type TXT");
    EXPECT_EQ(run.exit_code, 1) << run.output;
    EXPECT_NE(run.output.find("image 4"), std::string::npos) << run.output;
    EXPECT_EQ(run.output.find("view graph:"), std::string::npos)
        << "failed only after work: " << run.output;
    PrintCase(name.empty() ? "empty image name, TXT output"
                           : "image name with a newline, TXT output",
              LineWith(run.output, "ERROR"), run.exit_code, c.Unchanged(),
              ModelState(c.sparse + "/0", 0));
  }
}

TEST(Reliability, OutputProblemsFailBeforeWork) {
  {
    Case c;
    c.Freeze();
    std::ofstream(c.temp.File("a_file")) << "x";
    c.sparse = c.temp.File("a_file") + "/sparse";
    const RunResult run = c.Map();
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.output.find("view graph:"), std::string::npos) << run.output;
    PrintCase("output directory cannot be created (under a file)",
              LineWith(run.output, "ERROR"), run.exit_code, c.Unchanged(),
              "absent");
  }
  {
    Case c;
    c.Freeze();
    WriteOldModel(c.sparse + "/0");
    fs::create_directories(c.sparse + "/summary.json");
    const RunResult run = c.Map();
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.output.find("view graph:"), std::string::npos) << run.output;
    EXPECT_EQ(ModelState(c.sparse + "/0", 1, "old_marker.jpg"), "complete old");
    PrintCase("OUT/summary.json is a directory", LineWith(run.output, "ERROR"),
              run.exit_code, c.Unchanged(),
              ModelState(c.sparse + "/0", 1, "old_marker.jpg"));
  }
  {
    Case c;
    c.Freeze();
    fs::create_directories(c.sparse + "/0");
    std::ofstream(c.sparse + "/0/notes.txt") << "mine";
    const RunResult run = c.Map();
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(ReadText(c.sparse + "/0/notes.txt"), "mine");
    PrintCase("OUT/0 holds only a user's file (no model)",
              LineWith(run.output, "ERROR"), run.exit_code, c.Unchanged(),
              "absent (user's directory untouched)");
  }
}

TEST(Reliability, ReplacingAModelKeepsUserFilesAndWarnsAboutStaleOnes) {
  Case c;
  c.Freeze();
  WriteOldModel(c.sparse + "/0");
  std::ofstream(c.sparse + "/0/notes.txt") << "mine";
  WriteOldModel(c.sparse + "/3");  // after a gap
  // A temporary directory of a killed run (its PID no longer alive).
  pid_t dead = fork();
  if (dead == 0) _exit(0);
  waitpid(dead, nullptr, 0);
  const std::string stale_temp =
      c.sparse + "/.colmap_irav4_tmp." + std::to_string(dead);
  WriteOldModel(stale_temp + "/0");
  const RunResult run = c.Map();
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_EQ(ReadText(c.sparse + "/0/notes.txt"), "mine");
  EXPECT_NE(run.output.find("notes.txt: not a model file; kept"),
            std::string::npos)
      << run.output;
  EXPECT_NE(run.output.find("/3: left over from an earlier run"),
            std::string::npos)
      << run.output;
  EXPECT_FALSE(fs::exists(stale_temp));
  EXPECT_EQ(ModelState(c.sparse + "/0", 1, "old_marker.jpg"), "complete new");
  for (const auto& entry : fs::directory_iterator(c.sparse)) {
    EXPECT_EQ(entry.path().filename().string().find(".colmap_irav4_tmp"),
              std::string::npos)
        << entry.path();
  }
  PrintCase("OUT/0 old model + user file, stale OUT/3, dead run's temp dir",
            LineWith(run.output, "/3: left over"), run.exit_code, c.Unchanged(),
            ModelState(c.sparse + "/0", 1, "old_marker.jpg"));
}

TEST(Reliability, SigtermCleansTheTemporaryDirectoryAndKeepsTheOldModel) {
  for (const int signal_number : {SIGTERM, SIGINT}) {
    Case c;
    c.Freeze();
    WriteOldModel(c.sparse + "/0");
    const pid_t child = fork();
    if (child == 0) {
      const std::string log = c.temp.File("run.log");
      freopen(log.c_str(), "w", stdout);
      freopen(log.c_str(), "a", stderr);
      execl(COLMAP_IRAV4_BINARY, COLMAP_IRAV4_BINARY, "mapper",
            "--database_path", c.database.c_str(), "--output_path",
            c.sparse.c_str(), "--Mapper.num_threads", "2", nullptr);
      _exit(127);
    }
    const std::string temporary =
        c.sparse + "/.colmap_irav4_tmp." + std::to_string(child);
    // Wait until the run has started its work (its temporary directory
    // exists), then interrupt it.
    for (int k = 0; k < 600 && !fs::exists(temporary); ++k) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    ASSERT_TRUE(fs::exists(temporary));
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    kill(child, signal_number);
    int status = 0;
    waitpid(child, &status, 0);
    EXPECT_TRUE(WIFSIGNALED(status) || WIFEXITED(status));
    EXPECT_FALSE(fs::exists(temporary));
    // The run may have finished before the signal: then the new model is
    // complete; otherwise the old one is.
    const std::string state = ModelState(c.sparse + "/0", 1, "old_marker.jpg");
    EXPECT_TRUE(state == "complete old" || state == "complete new") << state;
    PrintCase(
        std::string(signal_number == SIGTERM ? "SIGTERM" : "SIGINT") +
            " during the run",
        WIFSIGNALED(status) ? "(killed by the signal; temporary "
                              "directory removed)"
                            : "(finished before the signal)",
        WIFSIGNALED(status) ? 128 + WTERMSIG(status) : WEXITSTATUS(status),
        c.Unchanged(), state);
  }
}

// A panorama as COLMAP's matcher leaves it: `num_images` PINHOLE images
// taken from one centre while turning 20 deg about the vertical axis each
// (and tilting a little), of points at 5-20 m all around; pairs sharing at
// least 30 points are stored as PLANAR_OR_PANORAMIC with H = K R K^-1 and
// E = [t]x R for an arbitrary unit t (with x2 ~ R x1, every t satisfies the
// epipolar constraint exactly, so a matcher's E carries no translation).
void WritePanoramaDatabase(const std::string& path, int num_images) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> depth(5, 20);
  std::normal_distribution<double> gaussian(0, 1);
  Camera camera;
  camera.camera_id = 1;
  camera.model_id = 1;  // PINHOLE
  camera.width = 640;
  camera.height = 480;
  camera.params = {500, 500, 320, 240};
  camera.has_prior_focal_length = true;
  Eigen::Matrix3d K;
  K << 500, 0, 320, 0, 500, 240, 0, 0, 1;
  std::vector<Eigen::Vector3d> points(3000);
  for (Eigen::Vector3d& point : points) {
    const Eigen::Vector3d direction(gaussian(rng), 0.3 * gaussian(rng),
                                    gaussian(rng));
    point = depth(rng) * direction.normalized();
  }
  std::vector<Eigen::Matrix3d> rotations;
  // keypoint index of each point in each image (-1: not seen).
  std::vector<std::vector<int>> index(num_images,
                                      std::vector<int>(points.size(), -1));
  DatabaseWriter writer(path);
  writer.WriteCamera(camera);
  for (int i = 0; i < num_images; ++i) {
    const Eigen::Matrix3d R =
        (Eigen::AngleAxisd(0.05 * std::sin(i), Eigen::Vector3d::UnitX()) *
         Eigen::AngleAxisd(i * 20.0 * M_PI / 180, Eigen::Vector3d::UnitY()))
            .toRotationMatrix();
    rotations.push_back(R);
    FeatureKeypoints keypoints;
    for (size_t p = 0; p < points.size(); ++p) {
      const Eigen::Vector3d x = K * (R * points[p]);
      if (x.z() < 0.1) continue;
      const Eigen::Vector2d xy =
          x.hnormalized() + 0.5 * Eigen::Vector2d(gaussian(rng), gaussian(rng));
      if (xy.x() < 1 || xy.y() < 1 || xy.x() > 639 || xy.y() > 479) continue;
      index[i][p] = static_cast<int>(keypoints.size());
      keypoints.push_back(xy.cast<float>());
    }
    const image_t image_id = static_cast<image_t>(i + 1);
    writer.WriteImage(image_id, "pano" + std::to_string(i) + ".jpg", 1);
    writer.WriteKeypoints(image_id, keypoints);
  }
  for (int i = 0; i < num_images; ++i) {
    for (int j = i + 1; j < num_images; ++j) {
      TwoViewGeometry geometry;
      geometry.image_id1 = static_cast<image_t>(i + 1);
      geometry.image_id2 = static_cast<image_t>(j + 1);
      for (size_t p = 0; p < points.size(); ++p) {
        if (index[i][p] >= 0 && index[j][p] >= 0) {
          geometry.inlier_matches.push_back(
              {static_cast<point2D_t>(index[i][p]),
               static_cast<point2D_t>(index[j][p])});
        }
      }
      if (geometry.inlier_matches.size() < 30) continue;
      geometry.config = TwoViewGeometry::PLANAR_OR_PANORAMIC;
      const Eigen::Matrix3d R = rotations[j] * rotations[i].transpose();
      const Eigen::Vector3d t =
          Eigen::Vector3d(gaussian(rng), gaussian(rng), gaussian(rng))
              .normalized();
      Eigen::Matrix3d t_cross;
      t_cross << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
      geometry.E = t_cross * R;
      geometry.F = K.inverse().transpose() * geometry.E * K.inverse();
      geometry.H = K * R * K.inverse();
      writer.WriteMatches(geometry.image_id1, geometry.image_id2,
                          geometry.inlier_matches);
      writer.WriteTwoViewGeometry(geometry);
    }
  }
  writer.Commit();
}

TEST(Reliability, PureRotationPanoramaIsReportedAsSuch) {
  TempDir temp;
  const std::string database = temp.File("panorama.db");
  WritePanoramaDatabase(database, 10);
  const uint64_t hash = HashFile(database);
  const std::string sparse = temp.File("sparse");
  const RunResult run =
      RunProgram("mapper --database_path " + database + " --output_path " +
                     sparse + " --Mapper.num_threads 2",
                 temp);
  const bool unchanged = HashFile(database) == hash &&
                         !fs::exists(database + "-wal") &&
                         !fs::exists(database + "-shm");
  // Exit 1 with the cause in the error itself, not "bundle adjustment
  // failed" or a model of poses without points.
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(LineWith(run.output, "ERROR").find("pure rotation (panorama)"),
            std::string::npos)
      << run.output;
  EXPECT_EQ(run.output.find("bundle adjustment failed"), std::string::npos)
      << run.output;
  EXPECT_TRUE(unchanged);
  EXPECT_FALSE(fs::exists(sparse + "/0"));
  PrintCase("pure rotation (panorama), 10 images from one centre",
            LineWith(run.output, "ERROR"), run.exit_code, unchanged,
            ModelState(sparse + "/0", 0));
}

TEST(Reliability, RelposeFileCases) {
  TempDir temp;
  const std::string q = " 1 0 0 0 0 0 1";
  const std::string q2 = " 0.9238795 0.3826834 0 0 0 0 1";
  struct Variant {
    std::string name, text, expected;
    int exit_code;
  };
  const std::vector<Variant> variants = {
      {"self-pair line",
       "a b" + q + " 20\nb c" + q + " 20\na c" + q + " 20\nb b" + q + " 20\n",
       "paired with itself, skipped", 0},
      {"conflicting duplicate line",
       "a b" + q + " 20\nb c" + q + " 20\na c" + q + " 20\na b" + q2 + " 20\n",
       "line 4: pair 'a' 'b' repeated with a rotation", 1},
      {"negative inlier count", "a b" + q + " -5\n",
       "line 1: inlier count -5 is negative", 1},
  };
  for (const Variant& variant : variants) {
    const std::string path = temp.File("relpose.txt");
    std::ofstream(path) << variant.text;
    const RunResult run =
        RunProgram("rotation_averager --relpose_path " + path +
                       " --output_path " + temp.File("rotations.txt"),
                   temp);
    EXPECT_EQ(run.exit_code, variant.exit_code) << run.output;
    EXPECT_NE(run.output.find(variant.expected), std::string::npos)
        << run.output;
    PrintCase(
        "relpose: " + variant.name, LineWith(run.output, variant.expected),
        run.exit_code, true,
        fs::exists(temp.File("rotations.txt")) ? "complete new" : "absent");
    fs::remove(temp.File("rotations.txt"));
  }
}

TEST(Reliability, ModelComparerCases) {
  TempDir temp;
  // Reference: 6 cameras on a line, rotated about z.
  Reconstruction reference;
  Camera camera;
  camera.camera_id = 1;
  camera.model_id = 0;
  camera.width = 100;
  camera.height = 100;
  camera.params = {100, 50, 50};
  reference.cameras[1] = camera;
  for (int k = 0; k < 6; ++k) {
    Image image;
    image.image_id = k + 1;
    image.camera_id = 1;
    image.name = "im" + std::to_string(k) + ".jpg";
    image.cam_from_world.rotation = Eigen::Quaterniond(
        Eigen::AngleAxisd(0.3 * k, Eigen::Vector3d::UnitZ()));
    // Centres on the x axis (plus tiny noise), so nearly collinear.
    const Eigen::Vector3d center(k, 1e-4 * (k % 2), 1e-4 * ((k + 1) % 3));
    image.cam_from_world.translation =
        -(image.cam_from_world.rotation * center);
    reference.images[image.image_id] = image;
  }
  WriteReconstruction(reference, temp.File("reference"), "BIN");
  // Model 1: the same poses with quaternions scaled by 3 (non-unit).
  Reconstruction scaled = reference;
  WriteReconstruction(scaled, temp.File("scaled"), "TXT");
  {
    std::string text = ReadText(temp.File("scaled/images.txt"));
    std::ofstream out(temp.File("scaled/images.txt"));
    std::istringstream lines(text);
    std::string line;
    int n = 0;
    while (std::getline(lines, line)) {
      if (line.empty() || line[0] == '#' || (n++ % 2) == 1) {
        out << line << "\n";
        continue;
      }
      std::istringstream fields(line);
      std::string id, name;
      double qw, qx, qy, qz, tx, ty, tz;
      int camera_id;
      fields >> id >> qw >> qx >> qy >> qz >> tx >> ty >> tz >> camera_id >>
          name;
      out.precision(17);
      out << id << " " << 3 * qw << " " << 3 * qx << " " << 3 * qy << " "
          << 3 * qz << " " << tx << " " << ty << " " << tz << " " << camera_id
          << " " << name << "\n";
    }
  }
  RunResult run =
      RunProgram("model_comparer --input_path1 " + temp.File("scaled") +
                     " --input_path2 " + temp.File("reference"),
                 temp);
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("nearly collinear"), std::string::npos)
      << run.output;
  {
    const std::string line = LineWith(run.output, "rotation error [deg]");
    double median = -1;
    std::sscanf(line.c_str(), "rotation error [deg]: median %lf", &median);
    EXPECT_LT(median, 0.01) << run.output;
    PrintCase("model_comparer: quaternions x3, collinear centres", line,
              run.exit_code, true, "n/a");
  }
  // A NaN quaternion.
  {
    std::string text = ReadText(temp.File("scaled/images.txt"));
    const size_t at = text.find("\n1 ");
    text.replace(at + 3, text.find(' ', at + 3) - (at + 3), "nan");
    std::ofstream(temp.File("scaled/images.txt")) << text;
  }
  run = RunProgram("model_comparer --input_path1 " + temp.File("scaled") +
                       " --input_path2 " + temp.File("reference"),
                   temp);
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find("invalid rotation quaternion"), std::string::npos)
      << run.output;
  EXPECT_EQ(run.output.find("median nan"), std::string::npos);
  PrintCase("model_comparer: NaN quaternion", LineWith(run.output, "ERROR"),
            run.exit_code, true, "n/a");
  run = RunProgram("model_comparer --input_path1 " + temp.File("reference") +
                       " --input_path2 " + temp.File("reference") +
                       " --Comparer.max_relative_error 5",
                   temp);
  EXPECT_EQ(run.exit_code, 1) << run.output;
  PrintCase("model_comparer: --Comparer.max_relative_error 5",
            LineWith(run.output, "ERROR"), run.exit_code, true, "n/a");
}

// Issue 28, item 1: an output path that is an input is refused before any
// work; the input is unchanged.
TEST(Reliability, OutputThatIsAnInputIsRefused) {
  Case c;
  c.Freeze();
  const std::string db = c.database;
  const std::vector<std::pair<std::string, std::string>> commands = {
      {"view_graph --output_path DB",
       "view_graph --database_path " + db + " --output_path " + db},
      {"rotation_averager --output_path DB",
       "rotation_averager --database_path " + db + " --output_path " + db},
      {"rotation_averager --summary_path DB",
       "rotation_averager --database_path " + db + " --summary_path " + db},
      {"rotation_averager --summary_path = --output_path",
       "rotation_averager --database_path " + db + " --output_path " +
           c.temp.File("r.txt") + " --summary_path " + c.temp.File("r.txt")},
  };
  for (const auto& [name, arguments] : commands) {
    const RunResult run = RunProgram(arguments, c.temp);
    EXPECT_EQ(run.exit_code, 1) << name << run.output;
    EXPECT_NE(run.output.find("is the same file as"), std::string::npos)
        << name << run.output;
    EXPECT_TRUE(c.Unchanged()) << name;
    PrintCase(name, LineWith(run.output, "ERROR"), run.exit_code, c.Unchanged(),
              "input unchanged");
  }
  // mapper with the database stored as OUT/summary.json.
  fs::create_directories(c.sparse);
  fs::copy_file(db, c.sparse + "/summary.json");
  const uint64_t hash = HashFile(c.sparse + "/summary.json");
  const RunResult run =
      RunProgram("mapper --database_path " + c.sparse +
                     "/summary.json --output_path " + c.sparse,
                 c.temp);
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_EQ(HashFile(c.sparse + "/summary.json"), hash);
  EXPECT_FALSE(fs::exists(c.sparse + "/0"));
  PrintCase("mapper --database_path OUT/summary.json --output_path OUT",
            LineWith(run.output, "ERROR"), run.exit_code,
            HashFile(c.sparse + "/summary.json") == hash, "absent");
}

// Issue 28, item 2: a named pipe or a device as an output is written into,
// never replaced by a regular file (never a real /dev entry here: a pipe,
// /dev/fd/1 and, as root, a device node of our own in the test directory).
TEST(Reliability, SpecialOutputFilesAreWrittenIntoNotReplaced) {
  Case c;
  c.Freeze();
  const std::string fifo = c.temp.File("fifo");
  const std::vector<std::pair<std::string, std::string>> commands = {
      {"view_graph --output_path FIFO",
       "view_graph --database_path " + c.database + " --output_path " + fifo},
      {"rotation_averager --output_path FIFO",
       "rotation_averager --database_path " + c.database + " --output_path " +
           fifo},
      {"rotation_averager --summary_path FIFO",
       "rotation_averager --database_path " + c.database + " --summary_path " +
           fifo},
  };
  for (const auto& [name, arguments] : commands) {
    ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
    std::string received;
    std::thread reader([&] { received = ReadText(fifo); });
    const RunResult run = RunProgram(arguments, c.temp);
    reader.join();
    struct stat status;
    ASSERT_EQ(lstat(fifo.c_str(), &status), 0);
    EXPECT_TRUE(S_ISFIFO(status.st_mode)) << name;
    EXPECT_EQ(run.exit_code, 0) << name << run.output;
    EXPECT_FALSE(received.empty()) << name;
    PrintCase(name, std::to_string(received.size()) + " bytes read from it",
              run.exit_code, c.Unchanged(),
              S_ISFIFO(status.st_mode) ? "still a pipe" : "REPLACED");
    fs::remove(fifo);
  }
  // /dev/fd/1: the relative poses go to the log (stdout).
  const RunResult run = RunProgram(
      "view_graph --database_path " + c.database + " --output_path /dev/fd/1",
      c.temp);
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("0000.jpg 0001.jpg"), std::string::npos)
      << run.output;
  // A character device node of our own (root only).
  const std::string device = c.temp.File("null_device");
  if (mknod(device.c_str(), S_IFCHR | 0600, makedev(1, 3)) == 0) {
    for (const std::string& arguments :
         {"view_graph --database_path " + c.database + " --output_path " +
              device,
          "rotation_averager --database_path " + c.database +
              " --summary_path " + device}) {
      const RunResult device_run = RunProgram(arguments, c.temp);
      struct stat status;
      ASSERT_EQ(lstat(device.c_str(), &status), 0);
      EXPECT_TRUE(S_ISCHR(status.st_mode)) << arguments;
      EXPECT_EQ(device_run.exit_code, 0) << device_run.output;
    }
    PrintCase("view_graph / rotation_averager to a character device", "-", 0,
              c.Unchanged(), "still a device");
  }
}

// Issue 28, item 3: a user's file named like a model file in OUT/0 is never
// deleted: the run refuses before any work, naming it.
TEST(Reliability, UserFilesNamedLikeModelFilesAreNotDeleted) {
  for (const std::string name : {"cameras.txt", "images.bin", "points3D.txt"}) {
    Case c;
    c.Freeze();
    fs::create_directories(c.sparse + "/0");
    std::ofstream(c.sparse + "/0/" + name) << "junk";
    std::ofstream(c.sparse + "/0/notes.txt") << "mine";
    const RunResult run = c.Map();
    EXPECT_EQ(run.exit_code, 1) << run.output;
    EXPECT_NE(run.output.find(name), std::string::npos) << run.output;
    EXPECT_EQ(run.output.find("view graph:"), std::string::npos) << run.output;
    EXPECT_EQ(ReadText(c.sparse + "/0/" + name), "junk");
    EXPECT_EQ(ReadText(c.sparse + "/0/notes.txt"), "mine");
    PrintCase("OUT/0/" + name + " of the user's (junk)",
              LineWith(run.output, "ERROR"), run.exit_code, c.Unchanged(),
              "user's files untouched");
  }
}

// Issue 28, item 5: a closed log stream (`mapper 2>&1 | head`) does not
// lose the run.
TEST(Reliability, ClosedLogStreamDoesNotLoseTheRun) {
  Case c;
  c.Freeze();
  const RunResult run = test::RunShell(
      "bash -c '" + std::string(COLMAP_IRAV4_BINARY) +
          " mapper --database_path " + c.database + " --output_path " +
          c.sparse + " --Mapper.num_threads 2 2>&1 | head -n 2; exit " +
          "${PIPESTATUS[0]}'",
      c.temp);
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_EQ(ModelState(c.sparse + "/0", 0), "complete new");
  EXPECT_TRUE(fs::exists(c.sparse + "/summary.json"));
  for (const auto& entry : fs::directory_iterator(c.sparse)) {
    EXPECT_EQ(entry.path().filename().string().find(".colmap_irav4_tmp"),
              std::string::npos);
  }
  PrintCase("mapper 2>&1 | head -n 2", "(log cut after 2 lines)", run.exit_code,
            c.Unchanged(), ModelState(c.sparse + "/0", 0));
}

// Issue 28, item 6: a failed run creates no output directory.
TEST(Reliability, FailedRunCreatesNoOutputDirectory) {
  TempDir temp;
  const std::string missing = temp.File("missing.db");
  for (const std::string& arguments :
       {"mapper --database_path " + missing + " --output_path " +
            temp.File("new/sparse"),
        "view_graph --database_path " + missing + " --output_path " +
            temp.File("new/poses.txt"),
        "rotation_averager --database_path " + missing + " --output_path " +
            temp.File("new/r.txt") + " --summary_path " +
            temp.File("new/s.json")}) {
    const RunResult run = RunProgram(arguments, temp);
    EXPECT_EQ(run.exit_code, 1) << run.output;
    EXPECT_NE(run.output.find(missing), std::string::npos) << run.output;
    EXPECT_FALSE(fs::exists(temp.File("new"))) << arguments;
    PrintCase(arguments.substr(0, arguments.find(' ')) + ": missing database",
              LineWith(run.output, "ERROR"), run.exit_code, true,
              fs::exists(temp.File("new")) ? "directory CREATED" : "nothing");
  }
}

// Issue 28, items 7 and 9: no model with a NaN or inf is written or read.
TEST(Reliability, NonFiniteModelsAreNeitherWrittenNorRead) {
  Case c;
  c.Freeze();
  const RunResult run = c.Map("--Normalization.extent inf");
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find("--Normalization.extent: must be positive and "
                            "finite"),
            std::string::npos)
      << run.output;
  EXPECT_FALSE(fs::exists(c.sparse));
  PrintCase("--Normalization.extent inf", LineWith(run.output, "ERROR"),
            run.exit_code, c.Unchanged(), ModelState(c.sparse + "/0", 0));
  // model_converter: a model with a NaN focal length, one with an inf point.
  for (const std::string what : {"NaN focal length", "inf point"}) {
    Reconstruction model = SmallModel({"1.jpg", "2.jpg"},
                                      what == "NaN focal length" ? NAN : 100.0);
    for (image_t id : {1, 2}) {
      model.images[id].points2D.resize(1);
      model.images[id].points2D[0].xy = Eigen::Vector2d(10, 10);
    }
    AddPoint3D(Eigen::Vector3d(what == "inf point" ? INFINITY : 0.0, 0, 5),
               {{1, 0}, {2, 0}}, &model);
    const std::string input = c.temp.File("bad_model");
    fs::create_directories(input);
    std::ofstream(input + "/cameras.bin", std::ios::binary)
        << CamerasBinaryBytes(model);
    std::ofstream(input + "/images.bin", std::ios::binary)
        << ImagesBinaryBytes(model);
    std::ofstream(input + "/points3D.bin", std::ios::binary)
        << Points3DBinaryBytes(model);
    const RunResult converted =
        RunProgram("model_converter --input_path " + input + " --output_path " +
                       c.temp.File("converted") + " --output_type TXT",
                   c.temp);
    EXPECT_EQ(converted.exit_code, 1) << converted.output;
    EXPECT_NE(converted.output.find("not finite"), std::string::npos)
        << converted.output;
    EXPECT_FALSE(fs::exists(c.temp.File("converted")));
    PrintCase("model_converter: " + what, LineWith(converted.output, "ERROR"),
              converted.exit_code, true, "absent");
  }
}

// Issue 28, item 10 and 12 (names): duplicate, NULL and NUL-holding image
// names are errors naming the images.
TEST(Reliability, ImageNamesMustBeUniqueNonEmptyWithoutNul) {
  struct Variant {
    std::string name, sql, expected;
  };
  const std::vector<Variant> variants = {
      {"duplicate name (no UNIQUE constraint)",
       "CREATE TABLE images2 AS SELECT * FROM images; DROP TABLE images; "
       "ALTER TABLE images2 RENAME TO images; "
       "UPDATE images SET name = '0000.jpg' WHERE image_id = 2;",
       "images 1 and 2 have the same name '0000.jpg'"},
      {"NULL name",
       "CREATE TABLE images2 AS SELECT * FROM images; DROP TABLE images; "
       "ALTER TABLE images2 RENAME TO images; "
       "UPDATE images SET name = NULL WHERE image_id = 3;",
       "image 3 has no name"},
      {"NUL byte inside a name",
       "UPDATE images SET name = CAST(X'30303030002E6A7067' AS TEXT) WHERE "
       "image_id = 4;",
       "image 4's name contains a NUL byte"},
      {"camera model stored as text",
       "UPDATE cameras SET model = 'PINHOLE' WHERE camera_id = 1;",
       "camera 1: model is the text 'PINHOLE', not COLMAP's integer model id"},
      {"NULL camera_id of an image",
       "CREATE TABLE images2 AS SELECT * FROM images; DROP TABLE images; "
       "ALTER TABLE images2 RENAME TO images; "
       "UPDATE images SET camera_id = NULL WHERE image_id = 2;",
       "image 2: camera_id is NULL"},
      {"focal length 1e300", "", "focal length 1e+300 px is implausible"},
      {"focal length 1e-300", "", "focal length 1e-300 px is implausible"},
  };
  for (const Variant& variant : variants) {
    Case c;
    {
      SqliteWriter writer(c.database);
      if (variant.name.rfind("focal length", 0) == 0) {
        const double focal =
            variant.name == "focal length 1e300" ? 1e300 : 1e-300;
        writer.Run("UPDATE cameras SET params = ? WHERE camera_id = 1",
                   {test::ToBlob(std::vector<double>{focal, 1536, 1024, 0})});
      } else {
        writer.Exec(variant.sql);
      }
    }
    c.Freeze();
    const RunResult run = c.Map();
    EXPECT_EQ(run.exit_code, 1) << variant.name << run.output;
    EXPECT_NE(run.output.find(variant.expected), std::string::npos)
        << variant.name << run.output;
    EXPECT_TRUE(c.Unchanged());
    EXPECT_FALSE(fs::exists(c.sparse)) << variant.name;
    PrintCase(variant.name, LineWith(run.output, "ERROR"), run.exit_code,
              c.Unchanged(), ModelState(c.sparse + "/0", 0));
  }
}

// Issue 28, items 12 and 13: an image file of another size than its camera
// is not used for colours (a warning), a named pipe under --image_path is
// never opened (no hang).
TEST(Reliability, ImagesOfAnotherSizeAndPipesAreNotUsedForColours) {
  Case c;
  c.Freeze();
  const std::string images = c.temp.File("images");
  fs::create_directories(images);
  // 0000.jpg: a 64 x 48 picture (the camera's is 3072 x 2048).
  std::ofstream(images + "/0000.jpg", std::ios::binary)
      << "P6\n64 48\n255\n"
      << std::string(64 * 48 * 3, '\x7f');
  ASSERT_EQ(mkfifo((images + "/0001.jpg").c_str(), 0600), 0);
  const auto start = std::chrono::steady_clock::now();
  const RunResult run =
      c.Map("--image_path " + images + " --Mapper.num_threads 2");
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_LT(seconds, 120);
  EXPECT_NE(run.output.find("0000.jpg: the image is 64 x 48 px, its camera "
                            "3072 x 2048 px"),
            std::string::npos)
      << run.output;
  EXPECT_NE(run.output.find("0001.jpg: not a regular file"), std::string::npos)
      << run.output;
  PrintCase("image of another size; a named pipe as an image",
            LineWith(run.output, "0001.jpg: not a regular"), run.exit_code,
            c.Unchanged(), ModelState(c.sparse + "/0", 0));
}

// Issue 28, item 14: messages that say what is wrong.
TEST(Reliability, MessagesNameTheRealProblem) {
  {
    // A dangling symbolic link as the output directory.
    Case c;
    c.Freeze();
    fs::create_symlink(c.temp.File("nowhere/sparse"), c.sparse);
    const RunResult run = c.Map();
    EXPECT_EQ(run.exit_code, 1) << run.output;
    EXPECT_NE(run.output.find("is a symbolic link to"), std::string::npos)
        << run.output;
    EXPECT_EQ(run.output.find("File exists"), std::string::npos) << run.output;
    PrintCase("output directory: a dangling symbolic link",
              LineWith(run.output, "ERROR"), run.exit_code, c.Unchanged(),
              "absent");
  }
  {
    // A name with a newline in an error: the error stays one line.
    Case c;
    {
      SqliteWriter writer(c.database);
      writer.Exec(
          "UPDATE images SET name = 'a' || char(10) || 'b.jpg', "
          "camera_id = 999 WHERE image_id = 1;");
    }
    c.Freeze();
    const RunResult run = c.Map();
    EXPECT_EQ(run.exit_code, 1) << run.output;
    const std::string error = LineWith(run.output, "ERROR");
    EXPECT_NE(error.find("'a\\nb.jpg' refers to camera 999"), std::string::npos)
        << run.output;
    PrintCase("image name with a newline in an error", error, run.exit_code,
              c.Unchanged(), "absent");
  }
}

// Issue 28, item 11: a track cap below what positioning needs is an error,
// not a model with cameras hundreds of metres off.
TEST(Reliability, TrackCapTooSmallToPositionIsAnError) {
  Case c;
  c.Freeze();
  const RunResult run = c.Map("--Mapper.max_num_tracks 1");
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find("--Mapper.max_num_tracks: 1 leaves image"),
            std::string::npos)
      << run.output;
  EXPECT_FALSE(fs::exists(c.sparse));
  PrintCase("--Mapper.max_num_tracks 1", LineWith(run.output, "ERROR"),
            run.exit_code, c.Unchanged(), ModelState(c.sparse + "/0", 0));
}

}  // namespace
}  // namespace colmap_irav4
