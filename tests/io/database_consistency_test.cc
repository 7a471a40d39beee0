// The database is read consistently (committed WAL content seen, uncommitted
// data never), a writer holding the lock is waited for a bounded time, and no
// file is ever created next to the database. Hostile records (self-pairs,
// pairs in both orders, pair ids out of range, invalid cameras, non-finite
// keypoints) give a clear error or a warning and a correct result.

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "colmap_irav4/io/database.h"
#include "colmap_irav4/io/database_writer.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/error.h"
#include "tests/test_utils/database_test_utils.h"

namespace colmap_irav4 {
namespace {

namespace fs = std::filesystem;
using test::CopyExampleDatabase;
using test::HashFile;
using test::SqliteWriter;
using test::TempDir;

constexpr int64_t kPairFactor = 2147483647;

std::set<std::string> DirectoryEntries(const std::string& dir) {
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) {
    names.insert(entry.path().filename().string());
  }
  return names;
}

std::string ErrorOf(const std::function<void()>& function) {
  try {
    function();
  } catch (const InputError& error) {
    return error.what();
  }
  return "";
}

TEST(DatabaseConsistency, CommittedWalContentOfAKilledWriterIsSeen) {
  TempDir temp;
  const std::string path = CopyExampleDatabase(temp);
  ASSERT_EQ(ReadDatabase(path).two_view_geometries.size(), 55u);
  // A writer (a child process) deletes every pair but 3, commits, and is
  // killed before any checkpoint: the change lives only in the -wal file.
  const pid_t child = fork();
  if (child == 0) {
    sqlite3* db = nullptr;
    sqlite3_open(path.c_str(), &db);
    sqlite3_exec(db, "PRAGMA wal_autocheckpoint=0;", nullptr, nullptr, nullptr);
    sqlite3_exec(db,
                 "DELETE FROM two_view_geometries WHERE pair_id NOT IN "
                 "(SELECT pair_id FROM two_view_geometries ORDER BY pair_id "
                 "LIMIT 3);",
                 nullptr, nullptr, nullptr);
    _exit(0);  // no close, no checkpoint
  }
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(fs::exists(path + "-wal"));
  ASSERT_TRUE(fs::exists(path + "-shm"));
  const std::set<std::string> entries = DirectoryEntries(temp.File(""));
  const uint64_t hash = HashFile(path);
  const uint64_t wal_hash = HashFile(path + "-wal");
  const DatabaseContents contents = ReadDatabase(path);
  EXPECT_EQ(contents.two_view_geometries.size(), 3u);
  EXPECT_EQ(HashFile(path), hash);
  EXPECT_EQ(HashFile(path + "-wal"), wal_hash);
  EXPECT_EQ(DirectoryEntries(temp.File("")), entries);

  // Without the -shm the WAL cannot be read without creating one: a clear
  // error, nothing created.
  fs::remove(path + "-shm");
  const std::string error = ErrorOf([&] { ReadDatabase(path); });
  EXPECT_NE(error.find(path + ": WAL-mode database with committed changes"),
            std::string::npos)
      << error;
  EXPECT_FALSE(fs::exists(path + "-shm"));
}

TEST(DatabaseConsistency, UncommittedWalDataIsNeverSeen) {
  TempDir temp;
  const std::string path = CopyExampleDatabase(temp);
  SqliteWriter writer(path);
  writer.Exec("BEGIN;");
  writer.Exec("DELETE FROM two_view_geometries;");
  // The writer's transaction is open: the reader sees the committed state.
  EXPECT_EQ(ReadDatabase(path).two_view_geometries.size(), 55u);
  writer.Exec("COMMIT;");
  EXPECT_EQ(ReadDatabase(path).two_view_geometries.size(), 0u);
}

TEST(DatabaseConsistency, LiveRollbackWriterIsWaitedForThenAClearError) {
  TempDir temp;
  const std::string path = temp.File("rollback.db");
  {
    SqliteWriter writer(path);
    writer.Exec("PRAGMA journal_mode=DELETE;");
    writer.Exec(Colmap38Schema());
    writer.Exec("INSERT INTO cameras VALUES (1, 0, 100, 100, x'" +
                std::string("0000000000005940000000000000494000000000000049"
                            "40") +
                "', 0);");
  }
  SqliteWriter writer(path);
  // A writer whose uncommitted pages spilled to the file holds the
  // exclusive lock (a tiny page cache forces the spill).
  writer.Exec("PRAGMA cache_size=1;");
  writer.Exec("BEGIN;");
  for (int k = 0; k < 200; ++k) {
    writer.Exec("INSERT INTO images VALUES (" + std::to_string(k + 1) +
                ", 'image" + std::to_string(k) +
                ".jpg', 1, NULL, NULL, NULL, NULL, NULL, NULL, NULL);");
  }
  ASSERT_TRUE(fs::exists(path + "-journal"));
  DatabaseReadOptions options;
  options.busy_timeout_ms = 300;
  const auto start = std::chrono::steady_clock::now();
  const std::string error = ErrorOf([&] { ReadDatabase(path, options); });
  const double waited =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  EXPECT_NE(error.find(path + ": database is locked by another process"),
            std::string::npos)
      << error;
  EXPECT_GE(waited, 0.25);
  writer.Exec("ROLLBACK;");
  // Once the writer is gone the committed (empty) state is read.
  EXPECT_TRUE(ReadDatabase(path, options).images.empty());
  EXPECT_FALSE(fs::exists(path + "-wal"));
  EXPECT_FALSE(fs::exists(path + "-shm"));
}

// Issue 28, item 14: a journal left by a killed writer is named as such,
// with how to recover it (not "attempt to write a readonly database").
TEST(DatabaseConsistency, KilledWritersJournalSaysHowToRecover) {
  TempDir temp;
  const std::string path = CopyExampleDatabase(temp);
  const pid_t child = fork();
  if (child == 0) {
    SqliteWriter writer(path);
    writer.Exec("PRAGMA journal_mode=DELETE;");
    writer.Exec("PRAGMA cache_size=1;");
    writer.Exec("BEGIN;");
    writer.Exec("UPDATE keypoints SET data = data || x'00';");
    _exit(0);  // killed before COMMIT or ROLLBACK
  }
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(fs::exists(path + "-journal"));
  const std::string error = ErrorOf([&] { ReadDatabase(path); });
  EXPECT_NE(error.find(path + ": a writer that crashed or was killed left a "
                              "journal"),
            std::string::npos)
      << error;
  EXPECT_EQ(error.find("readonly"), std::string::npos) << error;
}

// Issue 28, item 14: a live writer in exclusive locking mode (WAL without
// -shm) is named; no advice to checkpoint, which cannot work meanwhile.
TEST(DatabaseConsistency, ExclusiveWalWriterIsNamed) {
  TempDir temp;
  const std::string path = CopyExampleDatabase(temp);
  {
    // The writer below turns it into WAL mode already holding the file:
    // its WAL index is in its memory (no -shm file).
    SqliteWriter writer(path);
    writer.Exec("PRAGMA journal_mode=DELETE;");
  }
  int ready[2];
  ASSERT_EQ(pipe(ready), 0);
  const pid_t child = fork();
  if (child == 0) {
    SqliteWriter writer(path);
    writer.Exec("PRAGMA locking_mode=EXCLUSIVE;");
    writer.Exec("PRAGMA journal_mode=WAL;");
    writer.Exec("UPDATE images SET name = name;");
    (void)!write(ready[1], "x", 1);
    pause();
    _exit(0);
  }
  char byte = 0;
  ASSERT_EQ(read(ready[0], &byte, 1), 1);
  const std::string error = ErrorOf([&] { ReadDatabase(path); });
  kill(child, SIGKILL);
  waitpid(child, nullptr, 0);
  close(ready[0]);
  close(ready[1]);
  EXPECT_NE(error.find("held by process " + std::to_string(child)),
            std::string::npos)
      << error;
  EXPECT_EQ(error.find("wal_checkpoint"), std::string::npos) << error;
}

TEST(DatabaseConsistency, ReadOnlyWalDatabaseWithoutWalFileCreatesNothing) {
  TempDir temp;
  const std::string path = CopyExampleDatabase(temp);
  fs::permissions(path, fs::perms::owner_read);
  const std::set<std::string> entries = DirectoryEntries(temp.File(""));
  const uint64_t hash = HashFile(path);
  EXPECT_EQ(ReadDatabase(path).two_view_geometries.size(), 55u);
  EXPECT_EQ(DirectoryEntries(temp.File("")), entries);
  EXPECT_EQ(HashFile(path), hash);
}

TEST(DatabaseRecords, SelfPairsAndBothOrdersAreSkippedWithCounts) {
  TempDir temp;
  const std::string path = CopyExampleDatabase(temp);
  {
    SqliteWriter writer(path);
    const std::string copy_of_12 =
        ", rows, cols, data, config, F, E, H, qvec, tvec FROM "
        "two_view_geometries WHERE pair_id = " +
        std::to_string(kPairFactor * 1 + 2) + ";";
    writer.Exec("INSERT INTO two_view_geometries SELECT " +
                std::to_string(kPairFactor * 3 + 3) + copy_of_12);
    writer.Exec("INSERT INTO two_view_geometries SELECT " +
                std::to_string(kPairFactor * 2 + 1) + copy_of_12);
  }
  const DatabaseContents contents = ReadDatabase(path);
  EXPECT_EQ(contents.two_view_geometries.size(), 55u);
  EXPECT_EQ(contents.num_pairs_dropped.at("image paired with itself"), 1);
  EXPECT_EQ(contents.num_pairs_dropped.at("stored in both orders"), 1);
  for (const TwoViewGeometry& geometry : contents.two_view_geometries) {
    EXPECT_LT(geometry.image_id1, geometry.image_id2);
  }
}

TEST(DatabaseRecords, PairIdWithFirstImageIdOutOfRangeIsAnError) {
  TempDir temp;
  const std::string path = CopyExampleDatabase(temp);
  {
    SqliteWriter writer(path);
    writer.Exec("UPDATE two_view_geometries SET pair_id = " +
                std::to_string((int64_t{1} << 32) * kPairFactor + 2) +
                " WHERE pair_id = " + std::to_string(kPairFactor * 1 + 2) +
                ";");
  }
  const std::string error = ErrorOf([&] { ReadDatabase(path); });
  EXPECT_NE(error.find("first image id 4294967296 is out of range"),
            std::string::npos)
      << error;
}

TEST(DatabaseRecords, CameraIntrinsicsProblems) {
  Camera camera;
  camera.camera_id = 1;
  camera.width = 3072;
  camera.height = 2048;
  camera.model_id = CameraModelNameToId("SIMPLE_RADIAL");
  camera.params = {2760, 1536, 1024, -0.05};
  EXPECT_EQ(CameraIntrinsicsProblem(camera), "");
  for (const double k : {1e6, -5.0, 1e3}) {
    camera.params[3] = k;
    EXPECT_NE(CameraIntrinsicsProblem(camera).find("distortion"),
              std::string::npos)
        << k;
  }
  camera.params = {-999.8, 1536, 1024, 0};
  EXPECT_NE(CameraIntrinsicsProblem(camera).find("not positive"),
            std::string::npos);
  camera.params = {2760, NAN, 1024, 0};
  EXPECT_NE(CameraIntrinsicsProblem(camera).find("not finite"),
            std::string::npos);
  camera.params = {2760, 1e7, 1024, 0};
  EXPECT_NE(CameraIntrinsicsProblem(camera).find("principal point"),
            std::string::npos);
  // Real fisheye lenses pass.
  Camera fisheye;
  fisheye.camera_id = 2;
  fisheye.width = 848;
  fisheye.height = 800;
  fisheye.model_id = CameraModelNameToId("OPENCV_FISHEYE");
  fisheye.params = {286, 286, 424, 400, -0.01, 0.04, -0.04, 0.008};
  EXPECT_EQ(CameraIntrinsicsProblem(fisheye), "");
  const Camera reset = ResetCameraIntrinsics(camera);
  EXPECT_EQ(CameraIntrinsicsProblem(reset), "");
  EXPECT_DOUBLE_EQ(reset.params[0], 1.2 * 3072);
}

TEST(DatabaseRecords, NonFiniteKeypointsNeverBecomeObservations) {
  TempDir temp;
  const std::string path = CopyExampleDatabase(temp);
  const DatabaseContents before = ReadDatabase(path);
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    sqlite3_stmt* stmt = nullptr;
    sqlite3_prepare_v2(
        db, "SELECT rows, cols, data FROM keypoints WHERE image_id = 1", -1,
        &stmt, nullptr);
    ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
    const int rows = sqlite3_column_int(stmt, 0);
    const int cols = sqlite3_column_int(stmt, 1);
    std::vector<float> data(static_cast<size_t>(rows) * cols);
    std::memcpy(data.data(), sqlite3_column_blob(stmt, 2),
                data.size() * sizeof(float));
    sqlite3_finalize(stmt);
    for (int k = 0; k < rows; k += 2) data[k * cols] = NAN;
    sqlite3_prepare_v2(db, "UPDATE keypoints SET data = ? WHERE image_id = 1",
                       -1, &stmt, nullptr);
    sqlite3_bind_blob(stmt, 1, data.data(),
                      static_cast<int>(data.size() * sizeof(float)),
                      SQLITE_TRANSIENT);
    ASSERT_EQ(sqlite3_step(stmt), SQLITE_DONE);
    sqlite3_finalize(stmt);
    sqlite3_close(db);
  }
  const DatabaseContents contents = ReadDatabase(path);
  EXPECT_GT(contents.num_keypoints_invalid.at("non-finite keypoint"), 0);
  EXPECT_GT(contents.num_matches_dropped_invalid_keypoint, 0);
  for (const TwoViewGeometry& geometry : contents.two_view_geometries) {
    for (const FeatureMatch& match : geometry.inlier_matches) {
      if (geometry.image_id1 == 1) {
        EXPECT_TRUE(contents.keypoints.at(1)[match.point2D_idx1].allFinite());
      }
    }
  }
}

}  // namespace
}  // namespace colmap_irav4
