#include "colmap_irav4/io/database_writer.h"

#include <glog/logging.h>
#include <sqlite3.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

std::vector<uint32_t> MatchesBlob(const FeatureMatches& matches, bool swap) {
  std::vector<uint32_t> blob;
  blob.reserve(2 * matches.size());
  for (const FeatureMatch& match : matches) {
    blob.push_back(swap ? match.point2D_idx2 : match.point2D_idx1);
    blob.push_back(swap ? match.point2D_idx1 : match.point2D_idx2);
  }
  return blob;
}

void BindBlob(sqlite3_stmt* statement, int index, const void* data,
              size_t bytes) {
  sqlite3_bind_blob(statement, index, data, static_cast<int>(bytes),
                    SQLITE_TRANSIENT);
}

}  // namespace

const char* Colmap38Schema() {
  return R"sql(
CREATE TABLE cameras (camera_id INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL,
  model INTEGER NOT NULL, width INTEGER NOT NULL, height INTEGER NOT NULL,
  params BLOB, prior_focal_length INTEGER NOT NULL);
CREATE TABLE images (image_id INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL,
  name TEXT NOT NULL UNIQUE, camera_id INTEGER NOT NULL,
  prior_qw REAL, prior_qx REAL, prior_qy REAL, prior_qz REAL,
  prior_tx REAL, prior_ty REAL, prior_tz REAL,
  CONSTRAINT image_id_check CHECK(image_id >= 0 and image_id < 2147483647),
  FOREIGN KEY(camera_id) REFERENCES cameras(camera_id));
CREATE UNIQUE INDEX index_name ON images(name);
CREATE TABLE keypoints (image_id INTEGER PRIMARY KEY NOT NULL,
  rows INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB,
  FOREIGN KEY(image_id) REFERENCES images(image_id) ON DELETE CASCADE);
CREATE TABLE descriptors (image_id INTEGER PRIMARY KEY NOT NULL,
  rows INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB,
  FOREIGN KEY(image_id) REFERENCES images(image_id) ON DELETE CASCADE);
CREATE TABLE matches (pair_id INTEGER PRIMARY KEY NOT NULL,
  rows INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB);
CREATE TABLE two_view_geometries (pair_id INTEGER PRIMARY KEY NOT NULL,
  rows INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB,
  config INTEGER NOT NULL, F BLOB, E BLOB, H BLOB, qvec BLOB, tvec BLOB);
)sql";
}

DatabaseWriter::DatabaseWriter(const std::string& path) : path_(path) {
  if (std::filesystem::exists(path)) {
    throw InputError(path,
                     "exists; the database writer only creates new "
                     "databases");
  }
  temp_path_ = path + ".tmp" + std::to_string(getpid());
  std::error_code error;
  std::filesystem::remove(temp_path_, error);
  if (sqlite3_open_v2(temp_path_.c_str(), &db_,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE,
                      nullptr) != SQLITE_OK) {
    const std::string message = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw InputError(path, "cannot create (" + message + ")");
  }
  // A new file renamed only when complete: no journal needed.
  Exec("PRAGMA journal_mode=OFF; PRAGMA synchronous=OFF;");
  Exec(Colmap38Schema());
  Exec("BEGIN TRANSACTION;");
  camera_stmt_ = Prepare(
      "INSERT INTO cameras(camera_id, model, width, height, params, "
      "prior_focal_length) VALUES(?, ?, ?, ?, ?, ?);");
  image_stmt_ =
      Prepare("INSERT INTO images(image_id, name, camera_id) VALUES(?, ?, ?);");
  keypoints_stmt_ = Prepare(
      "INSERT INTO keypoints(image_id, rows, cols, data) VALUES(?, ?, ?, ?);");
  matches_stmt_ = Prepare(
      "INSERT INTO matches(pair_id, rows, cols, data) VALUES(?, ?, 2, ?);");
  geometry_stmt_ = Prepare(
      "INSERT INTO two_view_geometries(pair_id, rows, cols, data, config, F, "
      "E, H, qvec, tvec) VALUES(?, ?, 2, ?, ?, ?, ?, ?, ?, ?);");
}

DatabaseWriter::~DatabaseWriter() {
  for (sqlite3_stmt* statement : {camera_stmt_, image_stmt_, keypoints_stmt_,
                                  matches_stmt_, geometry_stmt_}) {
    sqlite3_finalize(statement);
  }
  if (db_) sqlite3_close(db_);
  if (!committed_) {
    std::error_code error;
    std::filesystem::remove(temp_path_, error);
  }
}

void DatabaseWriter::Fail(const std::string& problem) const {
  throw InputError(
      path_, problem + (db_ ? std::string(" (") + sqlite3_errmsg(db_) + ")"
                            : std::string()));
}

void DatabaseWriter::Exec(const std::string& sql) {
  char* error = nullptr;
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error) != SQLITE_OK) {
    const std::string message = error ? error : "";
    sqlite3_free(error);
    throw InputError(path_, "cannot write: " + message);
  }
}

sqlite3_stmt* DatabaseWriter::Prepare(const std::string& sql) {
  sqlite3_stmt* statement = nullptr;
  if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &statement, nullptr) !=
      SQLITE_OK) {
    Fail("cannot prepare " + sql);
  }
  return statement;
}

void DatabaseWriter::Step(sqlite3_stmt* statement, const std::string& what) {
  const int rc = sqlite3_step(statement);
  sqlite3_reset(statement);
  sqlite3_clear_bindings(statement);
  if (rc != SQLITE_DONE) Fail("cannot write " + what);
}

void DatabaseWriter::WriteCamera(const Camera& camera) {
  sqlite3_bind_int64(camera_stmt_, 1, camera.camera_id);
  sqlite3_bind_int64(camera_stmt_, 2, camera.model_id);
  sqlite3_bind_int64(camera_stmt_, 3, static_cast<int64_t>(camera.width));
  sqlite3_bind_int64(camera_stmt_, 4, static_cast<int64_t>(camera.height));
  BindBlob(camera_stmt_, 5, camera.params.data(),
           camera.params.size() * sizeof(double));
  sqlite3_bind_int64(camera_stmt_, 6, camera.has_prior_focal_length ? 1 : 0);
  Step(camera_stmt_, "camera " + std::to_string(camera.camera_id));
}

void DatabaseWriter::WriteImage(image_t image_id, const std::string& name,
                                camera_t camera_id) {
  sqlite3_bind_int64(image_stmt_, 1, image_id);
  sqlite3_bind_text(image_stmt_, 2, name.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_int64(image_stmt_, 3, camera_id);
  Step(image_stmt_, "image " + name);
}

void DatabaseWriter::WriteKeypoints(image_t image_id,
                                    const FeatureKeypoints& keypoints,
                                    const std::vector<float>& scales) {
  CHECK(scales.empty() || scales.size() == keypoints.size());
  const int cols = scales.empty() ? 2 : 4;
  std::vector<float> blob;
  blob.reserve(cols * keypoints.size());
  for (size_t k = 0; k < keypoints.size(); ++k) {
    blob.push_back(keypoints[k].x());
    blob.push_back(keypoints[k].y());
    if (cols == 4) {
      blob.push_back(scales[k]);
      blob.push_back(0.0f);
    }
  }
  sqlite3_bind_int64(keypoints_stmt_, 1, image_id);
  sqlite3_bind_int64(keypoints_stmt_, 2,
                     static_cast<int64_t>(keypoints.size()));
  sqlite3_bind_int64(keypoints_stmt_, 3, cols);
  BindBlob(keypoints_stmt_, 4, blob.data(), blob.size() * sizeof(float));
  Step(keypoints_stmt_, "keypoints of image " + std::to_string(image_id));
}

void DatabaseWriter::WriteMatches(image_t image_id1, image_t image_id2,
                                  const FeatureMatches& matches) {
  const std::vector<uint32_t> blob =
      MatchesBlob(matches, SwapImagePair(image_id1, image_id2));
  sqlite3_bind_int64(
      matches_stmt_, 1,
      static_cast<int64_t>(ImagePairToPairId(image_id1, image_id2)));
  sqlite3_bind_int64(matches_stmt_, 2, static_cast<int64_t>(matches.size()));
  BindBlob(matches_stmt_, 3, blob.data(), blob.size() * sizeof(uint32_t));
  Step(matches_stmt_, "matches of images " + std::to_string(image_id1) +
                          " and " + std::to_string(image_id2));
}

void DatabaseWriter::WriteTwoViewGeometry(const TwoViewGeometry& input) {
  const TwoViewGeometry geometry =
      SwapImagePair(input.image_id1, input.image_id2) ? input.Inverse() : input;
  const std::vector<uint32_t> blob =
      MatchesBlob(geometry.inlier_matches, false);
  sqlite3_bind_int64(geometry_stmt_, 1,
                     static_cast<int64_t>(ImagePairToPairId(
                         geometry.image_id1, geometry.image_id2)));
  sqlite3_bind_int64(geometry_stmt_, 2,
                     static_cast<int64_t>(geometry.inlier_matches.size()));
  BindBlob(geometry_stmt_, 3, blob.data(), blob.size() * sizeof(uint32_t));
  sqlite3_bind_int64(geometry_stmt_, 4, geometry.config);
  // Row-major, as COLMAP writes them.
  const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> F = geometry.F;
  const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> E = geometry.E;
  const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> H = geometry.H;
  BindBlob(geometry_stmt_, 5, F.data(), 9 * sizeof(double));
  BindBlob(geometry_stmt_, 6, E.data(), 9 * sizeof(double));
  BindBlob(geometry_stmt_, 7, H.data(), 9 * sizeof(double));
  const Eigen::Vector4d qvec =
      geometry.has_pose ? geometry.qvec : Eigen::Vector4d::Zero();
  const Eigen::Vector3d tvec =
      geometry.has_pose ? geometry.tvec : Eigen::Vector3d::Zero();
  BindBlob(geometry_stmt_, 8, qvec.data(), 4 * sizeof(double));
  BindBlob(geometry_stmt_, 9, tvec.data(), 3 * sizeof(double));
  Step(geometry_stmt_, "two_view_geometries of images " +
                           std::to_string(geometry.image_id1) + " and " +
                           std::to_string(geometry.image_id2));
}

void DatabaseWriter::Commit() {
  Exec("COMMIT;");
  for (sqlite3_stmt** statement :
       {&camera_stmt_, &image_stmt_, &keypoints_stmt_, &matches_stmt_,
        &geometry_stmt_}) {
    sqlite3_finalize(*statement);
    *statement = nullptr;
  }
  if (sqlite3_close(db_) != SQLITE_OK) Fail("cannot close");
  db_ = nullptr;
  std::error_code error;
  std::filesystem::rename(temp_path_, path_, error);
  if (error)
    throw InputError(path_,
                     "cannot rename " + temp_path_ + ": " + error.message());
  committed_ = true;
}

}  // namespace colmap_irav4
