#pragma once

// Helpers for tests that create small COLMAP databases with SQLite directly
// (in a temporary directory; the shared data is never written).

#include <sqlite3.h>

#include <sys/wait.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

#include <gtest/gtest.h>

#include "colmap_irav4/io/model_io.h"
#include "tests/test_utils/temp_dir.h"

namespace colmap_irav4 {
namespace test {

// Exit code (128 + signal when killed) and stdout + stderr of a shell
// command line, e.g. the program: RunShell(COLMAP_IRAV4_BINARY + args, temp)
// (the output goes through temp's run.log).
struct RunResult {
  int exit_code = -1;
  std::string output;
};

inline RunResult RunShell(const std::string& command_line,
                          const TempDir& temp) {
  const std::string log = temp.File("run.log");
  const std::string command = command_line + " > " + log + " 2>&1";
  RunResult result;
  const int status = std::system(command.c_str());
  result.exit_code =
      WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  std::ifstream file(log);
  result.output.assign(std::istreambuf_iterator<char>(file),
                       std::istreambuf_iterator<char>());
  return result;
}

// The whole text of a file ("" if it cannot be read).
inline std::string ReadText(const std::string& path) {
  std::ifstream file(path);
  return std::string(std::istreambuf_iterator<char>(file),
                     std::istreambuf_iterator<char>());
}

// A writable copy of the bundled example database (tests/data/fountain-P11.db)
// in `temp`.
inline std::string CopyExampleDatabase(const TempDir& temp) {
  const std::string copy = temp.File("database.db");
  std::filesystem::copy_file(
      std::string(COLMAP_IRAV4_SOURCE_DIR) + "/tests/data/fountain-P11.db",
      copy);
  std::filesystem::permissions(copy, std::filesystem::perms::owner_read |
                                         std::filesystem::perms::owner_write);
  return copy;
}

// FNV-1a 64-bit hash of a file's bytes (0 if it cannot be read).
inline uint64_t HashFile(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) return 0;
  std::ifstream file(path, std::ios::binary);
  if (!file) return 0;
  const std::string bytes((std::istreambuf_iterator<char>(file)),
                          std::istreambuf_iterator<char>());
  uint64_t hash = 1469598103934665603ull;
  for (const unsigned char c : bytes) {
    hash ^= c;
    hash *= 1099511628211ull;
  }
  return hash;
}

// A read-write connection for building test databases.
class SqliteWriter {
 public:
  explicit SqliteWriter(const std::string& path) {
    EXPECT_EQ(sqlite3_open(path.c_str(), &db_), SQLITE_OK);
    // Test files need no durability: skip the fsyncs.
    Exec("PRAGMA synchronous=OFF;");
  }
  ~SqliteWriter() { sqlite3_close(db_); }

  void Exec(const std::string& sql) {
    char* error = nullptr;
    const int rc = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error);
    EXPECT_EQ(rc, SQLITE_OK) << sql << ": " << (error ? error : "");
    sqlite3_free(error);
  }

  // Runs an INSERT/UPDATE with ? placeholders bound to integers, doubles or
  // blobs (vectors of bytes), in order.
  struct Value {
    enum Type { kInt, kDouble, kBlob, kNull } type;
    int64_t i = 0;
    double d = 0;
    std::vector<char> blob;
    Value(int64_t value) : type(kInt), i(value) {}
    Value(int value) : type(kInt), i(value) {}
    Value(double value) : type(kDouble), d(value) {}
    Value(std::vector<char> value) : type(kBlob), blob(std::move(value)) {}
    static Value Null() {
      Value value(0);
      value.type = kNull;
      return value;
    }
  };
  void Run(const std::string& sql, const std::vector<Value>& values) {
    sqlite3_stmt* stmt = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db_, sql.c_str(), -1, &stmt, nullptr),
              SQLITE_OK)
        << sql << ": " << sqlite3_errmsg(db_);
    for (size_t k = 0; k < values.size(); ++k) {
      const int index = static_cast<int>(k) + 1;
      const Value& value = values[k];
      switch (value.type) {
        case Value::kInt:
          sqlite3_bind_int64(stmt, index, value.i);
          break;
        case Value::kDouble:
          sqlite3_bind_double(stmt, index, value.d);
          break;
        case Value::kBlob:
          sqlite3_bind_blob(stmt, index, value.blob.data(),
                            static_cast<int>(value.blob.size()),
                            SQLITE_TRANSIENT);
          break;
        case Value::kNull:
          sqlite3_bind_null(stmt, index);
          break;
      }
    }
    EXPECT_EQ(sqlite3_step(stmt), SQLITE_DONE)
        << sql << ": " << sqlite3_errmsg(db_);
    sqlite3_finalize(stmt);
  }

 private:
  sqlite3* db_ = nullptr;
};

template <typename T>
std::vector<char> ToBlob(const std::vector<T>& values) {
  std::vector<char> blob(values.size() * sizeof(T));
  if (!blob.empty()) std::memcpy(blob.data(), values.data(), blob.size());
  return blob;
}

// COLMAP 4.x's schema: rigs, frames and pose priors; no images.prior_*.
inline const char* Colmap4Schema() {
  return R"sql(
CREATE TABLE rigs (rig_id INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL,
  ref_sensor_id INTEGER NOT NULL, ref_sensor_type INTEGER NOT NULL);
CREATE TABLE rig_sensors (rig_id INTEGER NOT NULL, sensor_id INTEGER NOT NULL,
  sensor_type INTEGER NOT NULL, sensor_from_rig BLOB,
  FOREIGN KEY(rig_id) REFERENCES rigs(rig_id) ON DELETE CASCADE);
CREATE TABLE cameras (camera_id INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL,
  model INTEGER NOT NULL, width INTEGER NOT NULL, height INTEGER NOT NULL,
  params BLOB, prior_focal_length INTEGER NOT NULL);
CREATE TABLE frames (frame_id INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL,
  rig_id INTEGER NOT NULL,
  FOREIGN KEY(rig_id) REFERENCES rigs(rig_id) ON DELETE CASCADE);
CREATE TABLE frame_data (frame_id INTEGER NOT NULL, data_id INTEGER NOT NULL,
  sensor_id INTEGER NOT NULL, sensor_type INTEGER NOT NULL,
  FOREIGN KEY(frame_id) REFERENCES frames(frame_id) ON DELETE CASCADE);
CREATE TABLE images (image_id INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL,
  name TEXT NOT NULL UNIQUE, camera_id INTEGER NOT NULL,
  CONSTRAINT image_id_check CHECK(image_id >= 0 and image_id < 2147483647),
  FOREIGN KEY(camera_id) REFERENCES cameras(camera_id));
CREATE TABLE pose_priors (pose_prior_id INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL,
  corr_data_id INTEGER NOT NULL, corr_sensor_id INTEGER NOT NULL,
  corr_sensor_type INTEGER NOT NULL, position BLOB, position_covariance BLOB,
  gravity BLOB, coordinate_system INTEGER NOT NULL);
CREATE TABLE keypoints (image_id INTEGER PRIMARY KEY NOT NULL,
  rows INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB,
  FOREIGN KEY(image_id) REFERENCES images(image_id) ON DELETE CASCADE);
CREATE TABLE descriptors (image_id INTEGER PRIMARY KEY NOT NULL,
  rows INTEGER NOT NULL, cols INTEGER NOT NULL, type INTEGER NOT NULL,
  data BLOB,
  FOREIGN KEY(image_id) REFERENCES images(image_id) ON DELETE CASCADE);
CREATE TABLE matches (pair_id INTEGER PRIMARY KEY NOT NULL,
  rows INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB);
CREATE TABLE two_view_geometries (pair_id INTEGER PRIMARY KEY NOT NULL,
  rows INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB,
  config INTEGER NOT NULL, F BLOB, E BLOB, H BLOB, qvec BLOB, tvec BLOB);
)sql";
}

// cam_from_world rotations of a COLMAP model's images, by image name.
inline std::map<std::string, Eigen::Matrix3d> ModelRotationsByName(
    const std::string& model_path) {
  std::map<std::string, Eigen::Matrix3d> rotations;
  for (const auto& [image_id, image] : ReadReconstruction(model_path).images) {
    rotations[image.name] = image.cam_from_world.rotation.toRotationMatrix();
  }
  return rotations;
}

}  // namespace test
}  // namespace colmap_irav4
