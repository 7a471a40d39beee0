#include "colmap_irav4/io/database.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include <glog/logging.h>
#include <sqlite3.h>

#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

// SQLite URI file name: '%', '?' and '#' (and non-printable bytes) must be
// percent-encoded.
std::string PathToUri(const std::string& path, bool immutable) {
  std::string uri = "file:";
  for (const unsigned char c : path) {
    if (c == '%' || c == '?' || c == '#' || c <= ' ' || c >= 0x7f) {
      char buffer[4];
      std::snprintf(buffer, sizeof(buffer), "%%%02X", c);
      uri += buffer;
    } else {
      uri += static_cast<char>(c);
    }
  }
  return uri + (immutable ? "?mode=ro&immutable=1" : "?mode=ro");
}

bool FileExists(const std::string& path) {
  struct stat info;
  return stat(path.c_str(), &info) == 0;
}

// The process holding an SQLite lock on the file (its lock bytes at 1 GiB),
// else 0: a writer in exclusive locking mode keeps it while it runs.
long LockHolder(const std::string& path) {
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return 0;
  struct flock lock;
  std::memset(&lock, 0, sizeof(lock));
  lock.l_type = F_WRLCK;
  lock.l_whence = SEEK_SET;
  lock.l_start = 0x40000000;
  lock.l_len = 512;
  const bool held = fcntl(fd, F_GETLK, &lock) == 0 && lock.l_type != F_UNLCK;
  close(fd);
  return held ? static_cast<long>(lock.l_pid) : 0;
}

int64_t FileSize(const std::string& path) {
  struct stat info;
  return stat(path.c_str(), &info) == 0 ? static_cast<int64_t>(info.st_size)
                                        : -1;
}

int64_t MtimeNs(const struct stat& info) {
  return static_cast<int64_t>(info.st_mtim.tv_sec) * 1000000000 +
         info.st_mtim.tv_nsec;
}

// Whether the file's header says WAL mode (file format versions 2 at bytes
// 18 and 19 of "SQLite format 3").
bool IsWalModeFile(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  char header[20];
  if (!file.read(header, sizeof(header))) return false;
  if (std::memcmp(header, "SQLite format 3", 16) != 0) return false;
  return header[18] == 2 || header[19] == 2;
}

// A message for SQLite's result code (busy/locked get the waiting context).
std::string SqliteProblem(sqlite3* db, int rc, int busy_timeout_ms) {
  // The extended code tells a hot journal from other read-only refusals.
  if (db != nullptr && (rc & 0xff) == (sqlite3_extended_errcode(db) & 0xff)) {
    rc = sqlite3_extended_errcode(db);
  }
  const int primary = rc & 0xff;
  if (primary == SQLITE_BUSY || primary == SQLITE_LOCKED) {
    return "database is locked by another process (waited " +
           std::to_string(busy_timeout_ms / 1000.0).substr(0, 4) +
           " s); retry when the writer (e.g. a running COLMAP command) has "
           "finished";
  }
  if (rc == SQLITE_READONLY_ROLLBACK || rc == SQLITE_READONLY_RECOVERY) {
    return "a writer that crashed or was killed left a journal (the "
           "-journal or -wal file next to it) that must be recovered before "
           "the database can be read; this program only reads. Recover it "
           "by opening the database read-write once, e.g. `sqlite3 DATABASE "
           "'PRAGMA integrity_check;'` or any COLMAP command on it, then "
           "retry";
  }
  return std::string("SQLite error: ") +
         (db != nullptr ? sqlite3_errmsg(db) : sqlite3_errstr(rc));
}

std::string Bytes(int num_bytes) {
  return std::to_string(num_bytes) + " bytes";
}

}  // namespace

// RAII prepared statement.
struct Database::Statement {
  Statement(const Database& database, const std::string& sql)
      : database_(database) {
    const int rc =
        sqlite3_prepare_v2(database.db_, sql.c_str(), -1, &stmt, nullptr);
    if (rc != SQLITE_OK) {
      const int primary = rc & 0xff;
      database.Fail(SqliteProblem(database.db_, rc, database.busy_timeout_ms_) +
                    (primary == SQLITE_BUSY || primary == SQLITE_LOCKED
                         ? ""
                         : " (in '" + sql + "')"));
    }
  }
  ~Statement() { sqlite3_finalize(stmt); }
  // True while there is a row.
  bool Step() {
    const int rc = sqlite3_step(stmt);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    database_.Fail(
        SqliteProblem(database_.db_, rc, database_.busy_timeout_ms_));
  }
  int64_t Int(int column) const { return sqlite3_column_int64(stmt, column); }
  double Double(int column) const {
    return sqlite3_column_double(stmt, column);
  }
  bool IsNull(int column) const {
    return sqlite3_column_type(stmt, column) == SQLITE_NULL;
  }
  // "" if the column holds an integer, else what it holds ("NULL", "the
  // text 'PINHOLE'", ...): an id read as an integer would silently be 0.
  std::string NotInteger(int column) const {
    switch (sqlite3_column_type(stmt, column)) {
      case SQLITE_INTEGER:
        return "";
      case SQLITE_NULL:
        return "NULL";
      case SQLITE_TEXT:
        return "the text '" + Text(column) + "'";
      case SQLITE_FLOAT:
        return "the real number " +
               std::to_string(sqlite3_column_double(stmt, column));
      default:
        return "a blob";
    }
  }
  std::string Text(int column) const {
    const unsigned char* text = sqlite3_column_text(stmt, column);
    // All bytes: a NUL inside must be seen by the checks, not cut the text.
    return text == nullptr
               ? std::string()
               : std::string(
                     reinterpret_cast<const char*>(text),
                     static_cast<size_t>(sqlite3_column_bytes(stmt, column)));
  }
  const void* Blob(int column) const {
    return sqlite3_column_blob(stmt, column);
  }
  int BlobBytes(int column) const { return sqlite3_column_bytes(stmt, column); }
  void Bind(int index, int64_t value) {
    sqlite3_bind_int64(stmt, index, value);
  }

  const Database& database_;
  sqlite3_stmt* stmt = nullptr;
};

std::string DatabaseSchema::Description() const {
  if (has_rigs_table || has_frames_table) return "COLMAP 4.x";
  if (has_pose_priors_table) return "COLMAP 3.10+";
  if (has_two_view_pose) return "COLMAP 3.8/3.9";
  return "COLMAP <= 3.7";
}

void Database::Fail(const std::string& problem) const {
  throw InputError(path_, problem);
}

Database::Database(const std::string& path, const DatabaseReadOptions& options)
    : path_(path), busy_timeout_ms_(std::max(0, options.busy_timeout_ms)) {
  struct stat info;
  if (stat(path.c_str(), &info) != 0) {
    Fail(std::string("cannot open database: ") + std::strerror(errno));
  }
  if (!S_ISREG(info.st_mode)) Fail("cannot open database: not a regular file");
  opened_size_ = static_cast<int64_t>(info.st_size);
  opened_mtime_ns_ = MtimeNs(info);
  // See the class comment: which open mode reads committed content without
  // creating a file next to the database.
  if (IsWalModeFile(path)) {
    const int64_t wal_size = FileSize(path + "-wal");
    if (wal_size <= 0) {
      open_mode_ = DatabaseOpenMode::kImmutable;
    } else if (!FileExists(path + "-shm")) {
      const long holder = LockHolder(path);
      if (holder != 0) {
        Fail("WAL-mode database held by process " + std::to_string(holder) +
             " (a writer in exclusive locking mode: no -shm file): its "
             "changes are in the -wal file, which cannot be read while it "
             "holds the database; retry when it has finished");
      }
      Fail(
          "WAL-mode database with committed changes in its -wal file but "
          "no -shm file: reading it would create a -shm file next to it. "
          "Recover it once with `sqlite3 " +
          path +
          " 'PRAGMA wal_checkpoint;'` (or by opening it with COLMAP), "
          "then retry");
    }
  }
  const bool immutable = open_mode_ == DatabaseOpenMode::kImmutable;
  const int open_rc =
      sqlite3_open_v2(PathToUri(path, immutable).c_str(), &db_,
                      SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr);
  if (open_rc != SQLITE_OK) {
    const std::string message =
        db_ != nullptr ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    Fail("cannot open database: " + message);
  }
  sqlite3_busy_timeout(db_, busy_timeout_ms_);
  try {
    std::set<std::string> tables;
    {
      // One read transaction for every statement of this object: all of them
      // see the same committed snapshot.
      if (sqlite3_exec(db_, "BEGIN", nullptr, nullptr, nullptr) != SQLITE_OK) {
        Fail(SqliteProblem(db_, sqlite3_errcode(db_), busy_timeout_ms_));
      }
      // The first read of the file: fails here if it is not SQLite.
      sqlite3_stmt* probe = nullptr;
      int rc = sqlite3_prepare_v2(db_, "SELECT count(*) FROM sqlite_master", -1,
                                  &probe, nullptr);
      if (rc == SQLITE_OK) {
        rc = sqlite3_step(probe);
        if (rc == SQLITE_ROW) rc = SQLITE_OK;
      }
      sqlite3_finalize(probe);
      if ((rc & 0xff) == SQLITE_NOTADB) Fail("not an SQLite database");
      if (rc != SQLITE_OK) Fail(SqliteProblem(db_, rc, busy_timeout_ms_));
      Statement statement(*this,
                          "SELECT name FROM sqlite_master WHERE type='table'");
      while (statement.Step()) tables.insert(statement.Text(0));
    }
    for (const char* table :
         {"cameras", "images", "keypoints", "two_view_geometries"}) {
      if (tables.count(table) == 0) {
        Fail(std::string("not a COLMAP database: table '") + table +
             "' is missing");
      }
    }
    const std::map<std::string, std::vector<std::string>> required_columns = {
        {"cameras", {"camera_id", "model", "width", "height", "params"}},
        {"images", {"image_id", "name", "camera_id"}},
        {"keypoints", {"image_id", "rows", "cols", "data"}},
        {"two_view_geometries", {"pair_id", "rows", "cols", "data", "config"}},
    };
    for (const auto& [table, columns] : required_columns) {
      const std::set<std::string> present = TableColumns(table);
      for (const std::string& column : columns) {
        if (present.count(column) == 0) {
          Fail("table '" + table + "' has no column '" + column + "'");
        }
      }
    }
    schema_.has_matches_table = tables.count("matches") > 0;
    if (schema_.has_matches_table) {
      const std::set<std::string> columns = TableColumns("matches");
      for (const char* column : {"pair_id", "rows", "cols", "data"}) {
        if (columns.count(column) == 0) {
          Fail(std::string("table 'matches' has no column '") + column + "'");
        }
      }
    }
    const std::set<std::string> tvg_columns =
        TableColumns("two_view_geometries");
    for (const char* column : {"F", "E", "H"}) {
      if (tvg_columns.count(column) == 0) {
        Fail(std::string("table 'two_view_geometries' has no column '") +
             column + "'");
      }
    }
    schema_.has_two_view_pose =
        tvg_columns.count("qvec") > 0 && tvg_columns.count("tvec") > 0;
    const std::set<std::string> image_columns = TableColumns("images");
    schema_.has_image_prior_columns = true;
    for (const char* column : {"prior_qw", "prior_qx", "prior_qy", "prior_qz",
                               "prior_tx", "prior_ty", "prior_tz"}) {
      if (image_columns.count(column) == 0) {
        schema_.has_image_prior_columns = false;
      }
    }
    schema_.has_pose_priors_table = tables.count("pose_priors") > 0;
    schema_.has_rigs_table = tables.count("rigs") > 0;
    schema_.has_frames_table = tables.count("frames") > 0;
    schema_.has_frame_data_table = tables.count("frame_data") > 0;
  } catch (...) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;
  }
}

Database::~Database() {
  if (db_ != nullptr) {
    sqlite3_exec(db_, "COMMIT", nullptr, nullptr, nullptr);
    sqlite3_close(db_);
  }
}

void Database::CheckUnchanged() const {
  if (open_mode_ != DatabaseOpenMode::kImmutable) return;
  struct stat info;
  const bool same = stat(path_.c_str(), &info) == 0 &&
                    static_cast<int64_t>(info.st_size) == opened_size_ &&
                    MtimeNs(info) == opened_mtime_ns_ &&
                    FileSize(path_ + "-wal") <= 0;
  if (!same) {
    Fail(
        "changed while it was being read (another process is writing it); "
        "retry when the writer has finished");
  }
}

std::set<std::string> Database::TableColumns(const std::string& table) const {
  std::set<std::string> columns;
  Statement statement(*this, "PRAGMA table_info(" + table + ")");
  while (statement.Step()) columns.insert(statement.Text(1));
  return columns;
}

std::vector<Camera> Database::ReadAllCameras() const {
  std::vector<Camera> cameras;
  const bool has_prior_focal_length =
      TableColumns("cameras").count("prior_focal_length") > 0;
  Statement statement(
      *this, std::string("SELECT camera_id, model, width, height, params") +
                 (has_prior_focal_length ? ", prior_focal_length" : "") +
                 " FROM cameras ORDER BY camera_id");
  while (statement.Step()) {
    Camera camera;
    if (!statement.NotInteger(0).empty()) {
      Fail("a row of the cameras table has camera_id " +
           statement.NotInteger(0) + " (not an integer id)");
    }
    const int64_t camera_id = statement.Int(0);
    const std::string what = "camera " + std::to_string(camera_id);
    if (!statement.NotInteger(1).empty()) {
      Fail(what + ": model is " + statement.NotInteger(1) +
           ", not COLMAP's integer model id (e.g. 1 for PINHOLE)");
    }
    if (camera_id < 0 || camera_id >= kInvalidCameraId) {
      Fail(what + ": camera_id out of range");
    }
    camera.camera_id = static_cast<camera_t>(camera_id);
    const int64_t model_id = statement.Int(1);
    if (!IsValidCameraModelId(static_cast<int>(model_id)) ||
        model_id != static_cast<int>(model_id)) {
      Fail(what + ": unknown camera model id " + std::to_string(model_id) +
           " (COLMAP's are 0-" + std::to_string(kNumCameraModels - 1) + ")");
    }
    camera.model_id = static_cast<int>(model_id);
    if (statement.Int(2) <= 0 || statement.Int(3) <= 0) {
      Fail(what + ": invalid image size " + std::to_string(statement.Int(2)) +
           " x " + std::to_string(statement.Int(3)));
    }
    camera.width = static_cast<uint64_t>(statement.Int(2));
    camera.height = static_cast<uint64_t>(statement.Int(3));
    const int num_params = CameraModelNumParams(camera.model_id);
    const int bytes = statement.BlobBytes(4);
    if (bytes != num_params * static_cast<int>(sizeof(double))) {
      Fail(what + ": params blob has " + Bytes(bytes) + ", " +
           CameraModelIdToName(camera.model_id) + " expects " +
           std::to_string(num_params) + " doubles (" +
           Bytes(num_params * static_cast<int>(sizeof(double))) + ")");
    }
    camera.params.resize(num_params);
    std::memcpy(camera.params.data(), statement.Blob(4), bytes);
    camera.has_prior_focal_length =
        has_prior_focal_length && statement.Int(5) != 0;
    cameras.push_back(std::move(camera));
  }
  return cameras;
}

std::vector<DatabaseImage> Database::ReadAllImages() const {
  std::vector<DatabaseImage> images;
  std::string sql = "SELECT image_id, name, camera_id";
  if (schema_.has_image_prior_columns) {
    sql +=
        ", prior_qw, prior_qx, prior_qy, prior_qz, prior_tx, prior_ty, "
        "prior_tz";
  }
  sql += " FROM images ORDER BY image_id";
  Statement statement(*this, sql);
  std::map<image_t, size_t> index;
  while (statement.Step()) {
    DatabaseImage image;
    if (!statement.NotInteger(0).empty()) {
      Fail("a row of the images table has image_id " + statement.NotInteger(0) +
           " (not an integer id)");
    }
    const int64_t image_id = statement.Int(0);
    if (!statement.NotInteger(2).empty()) {
      Fail("image " + std::to_string(image_id) + ": camera_id is " +
           statement.NotInteger(2) + " (not an integer id)");
    }
    if (image_id < 0 || image_id >= static_cast<int64_t>(kMaxNumImages)) {
      Fail("image " + std::to_string(image_id) + ": image_id out of range");
    }
    image.image_id = static_cast<image_t>(image_id);
    image.name = statement.Text(1);
    image.camera_id = static_cast<camera_t>(statement.Int(2));
    if (schema_.has_image_prior_columns) {
      bool rotation = true, position = true;
      for (int k = 0; k < 4; ++k) rotation &= !statement.IsNull(3 + k);
      for (int k = 0; k < 3; ++k) position &= !statement.IsNull(7 + k);
      if (rotation) {
        image.prior_qvec =
            Eigen::Vector4d(statement.Double(3), statement.Double(4),
                            statement.Double(5), statement.Double(6));
        image.has_prior_rotation = image.prior_qvec.norm() > 0;
      }
      if (position) {
        image.prior_tvec = Eigen::Vector3d(
            statement.Double(7), statement.Double(8), statement.Double(9));
        image.has_prior_position = true;
      }
    }
    index[image.image_id] = images.size();
    images.push_back(std::move(image));
  }
  return images;
}

float KeypointScale(const float* data, int cols) {
  if (cols == 4) return data[2];
  if (cols == 6) {
    // COLMAP's FeatureKeypoint::ComputeScale: the mean length of the affine
    // shape's two columns.
    return 0.5f * (std::hypot(data[2], data[4]) + std::hypot(data[3], data[5]));
  }
  return 0.0f;
}

FeatureKeypoints Database::ReadKeypoints(image_t image_id,
                                         std::vector<float>* scales) const {
  if (scales != nullptr) scales->clear();
  Statement statement(
      *this, "SELECT rows, cols, data FROM keypoints WHERE image_id = ?");
  statement.Bind(1, image_id);
  FeatureKeypoints keypoints;
  if (!statement.Step()) return keypoints;
  const std::string what = "keypoints of image " + std::to_string(image_id);
  const int64_t rows = statement.Int(0);
  const int64_t cols = statement.Int(1);
  if (rows < 0) Fail(what + ": negative row count");
  if (rows == 0) return keypoints;
  if (cols != 2 && cols != 4 && cols != 6) {
    Fail(what + ": " + std::to_string(cols) + " columns, expected 2, 4 or 6");
  }
  // A blob holds at most INT_MAX bytes: a larger row count cannot match its
  // blob, and its byte count could overflow.
  if (rows > std::numeric_limits<int>::max() /
                 (cols * static_cast<int64_t>(sizeof(float)))) {
    Fail(what + ": row count " + std::to_string(rows) +
         " is larger than a blob can hold");
  }
  const int64_t expected = rows * cols * static_cast<int64_t>(sizeof(float));
  const int bytes = statement.BlobBytes(2);
  if (bytes != expected) {
    Fail(what + ": data blob has " + Bytes(bytes) + ", expected " +
         std::to_string(rows) + " x " + std::to_string(cols) + " floats (" +
         std::to_string(expected) + " bytes)");
  }
  const float* data = static_cast<const float*>(statement.Blob(2));
  keypoints.resize(rows);
  for (int64_t i = 0; i < rows; ++i) {
    keypoints[i] = Eigen::Vector2f(data[i * cols], data[i * cols + 1]);
  }
  if (scales != nullptr && cols > 2) {
    scales->resize(rows);
    for (int64_t i = 0; i < rows; ++i) {
      (*scales)[i] = KeypointScale(data + i * cols, static_cast<int>(cols));
    }
  }
  return keypoints;
}

std::map<image_t, int> Database::ReadNumKeypoints() const {
  std::map<image_t, int> num_keypoints;
  Statement statement(*this, "SELECT image_id, rows FROM keypoints");
  while (statement.Step()) {
    num_keypoints[static_cast<image_t>(statement.Int(0))] =
        static_cast<int>(statement.Int(1));
  }
  return num_keypoints;
}

namespace {

// Decodes an N x 2 uint32 match blob, checking its size.
bool DecodeMatches(int64_t rows, int64_t cols, const void* blob, int bytes,
                   FeatureMatches* matches, std::string* problem) {
  matches->clear();
  if (rows < 0) {
    *problem = "negative row count";
    return false;
  }
  if (rows == 0) return true;
  if (cols != 2) {
    *problem = std::to_string(cols) + " columns, expected 2";
    return false;
  }
  // A blob holds at most INT_MAX bytes: a larger row count cannot match its
  // blob, and its byte count could overflow.
  if (rows > std::numeric_limits<int>::max() /
                 (2 * static_cast<int64_t>(sizeof(uint32_t)))) {
    *problem =
        "row count " + std::to_string(rows) + " is larger than a blob can hold";
    return false;
  }
  const int64_t expected = rows * 2 * static_cast<int64_t>(sizeof(uint32_t));
  if (bytes != expected) {
    *problem = "data blob has " + std::to_string(bytes) + " bytes, expected " +
               std::to_string(rows) + " x 2 uint32 (" +
               std::to_string(expected) + " bytes)";
    return false;
  }
  const uint32_t* data = static_cast<const uint32_t*>(blob);
  matches->resize(rows);
  for (int64_t i = 0; i < rows; ++i) {
    (*matches)[i].point2D_idx1 = data[2 * i];
    (*matches)[i].point2D_idx2 = data[2 * i + 1];
  }
  return true;
}

std::string PairName(image_pair_t pair_id) {
  const auto [id1, id2] = PairIdToImagePair(pair_id);
  return "pair (" + std::to_string(id1) + ", " + std::to_string(id2) + ")";
}

}  // namespace

FeatureMatches Database::ReadMatches(image_t image_id1,
                                     image_t image_id2) const {
  FeatureMatches matches;
  if (!schema_.has_matches_table) return matches;
  const image_pair_t pair_id = ImagePairToPairId(image_id1, image_id2);
  Statement statement(*this,
                      "SELECT rows, cols, data FROM matches WHERE pair_id = ?");
  statement.Bind(1, static_cast<int64_t>(pair_id));
  if (!statement.Step()) return matches;
  std::string problem;
  if (!DecodeMatches(statement.Int(0), statement.Int(1), statement.Blob(2),
                     statement.BlobBytes(2), &matches, &problem)) {
    Fail("matches of " + PairName(pair_id) + ": " + problem);
  }
  if (SwapImagePair(image_id1, image_id2)) {
    for (FeatureMatch& match : matches) {
      std::swap(match.point2D_idx1, match.point2D_idx2);
    }
  }
  return matches;
}

std::map<image_pair_t, int> Database::ReadNumMatches() const {
  std::map<image_pair_t, int> num_matches;
  if (!schema_.has_matches_table) return num_matches;
  Statement statement(*this, "SELECT pair_id, rows FROM matches");
  while (statement.Step()) {
    num_matches[static_cast<image_pair_t>(statement.Int(0))] =
        static_cast<int>(statement.Int(1));
  }
  return num_matches;
}

TwoViewGeometry Database::ReadTwoViewGeometryRow(Statement* statement) const {
  // Columns: pair_id, rows, cols, data, config, F, E, H [, qvec, tvec].
  TwoViewGeometry geometry;
  const int64_t pair_id = statement->Int(0);
  if (pair_id < 0) Fail("two_view_geometries: negative pair_id");
  // A first image id >= 2^31 - 1 would alias onto another pair when decoded
  // into 32-bit ids.
  if (static_cast<uint64_t>(pair_id) / kMaxNumImages >= kMaxNumImages) {
    Fail("two_view_geometries row with pair_id " + std::to_string(pair_id) +
         ": its first image id " +
         std::to_string(static_cast<uint64_t>(pair_id) / kMaxNumImages) +
         " is out of range (COLMAP's pair_id is 2147483647 * image_id1 + "
         "image_id2 with image ids < 2147483647)");
  }
  const auto [id1, id2] = PairIdToImagePair(static_cast<image_pair_t>(pair_id));
  geometry.image_id1 = id1;
  geometry.image_id2 = id2;
  const std::string what =
      "two_view_geometries of " + PairName(static_cast<image_pair_t>(pair_id));
  std::string problem;
  if (!DecodeMatches(statement->Int(1), statement->Int(2), statement->Blob(3),
                     statement->BlobBytes(3), &geometry.inlier_matches,
                     &problem)) {
    Fail(what + ": " + problem);
  }
  geometry.config = static_cast<int>(statement->Int(4));
  const char* const names[] = {"F", "E", "H"};
  Eigen::Matrix3d* matrices[] = {&geometry.F, &geometry.E, &geometry.H};
  for (int k = 0; k < 3; ++k) {
    const int bytes = statement->BlobBytes(5 + k);
    if (bytes == 0) continue;  // NULL or empty: not estimated
    if (bytes != 9 * static_cast<int>(sizeof(double))) {
      Fail(what + ": " + names[k] + " blob has " + Bytes(bytes) +
           ", expected 3 x 3 doubles (72 bytes)");
    }
    // Row-major in the database.
    Eigen::Matrix<double, 3, 3, Eigen::RowMajor> M;
    std::memcpy(M.data(), statement->Blob(5 + k), bytes);
    *matrices[k] = M;
  }
  if (schema_.has_two_view_pose) {
    const int q_bytes = statement->BlobBytes(8);
    const int t_bytes = statement->BlobBytes(9);
    if (q_bytes != 0 || t_bytes != 0) {
      if (q_bytes != 4 * static_cast<int>(sizeof(double))) {
        Fail(what + ": qvec blob has " + Bytes(q_bytes) +
             ", expected 4 doubles (32 bytes)");
      }
      if (t_bytes != 3 * static_cast<int>(sizeof(double))) {
        Fail(what + ": tvec blob has " + Bytes(t_bytes) +
             ", expected 3 doubles (24 bytes)");
      }
      Eigen::Vector4d qvec;
      Eigen::Vector3d tvec;
      std::memcpy(qvec.data(), statement->Blob(8), q_bytes);
      std::memcpy(tvec.data(), statement->Blob(9), t_bytes);
      // COLMAP 3.8 stores zeros unless asked to estimate the pose; identity
      // with zero translation carries no information either.
      const bool zero = !(qvec.norm() > 1e-6);
      const bool identity =
          tvec.isZero(0) && qvec(0) != 0 && qvec.tail<3>().isZero(0);
      if (!zero && !identity) {
        geometry.has_pose = true;
        geometry.qvec = qvec.normalized();
        geometry.tvec = tvec;
      }
    }
  }
  return geometry;
}

bool Database::ReadTwoViewGeometry(image_t image_id1, image_t image_id2,
                                   TwoViewGeometry* geometry) const {
  std::string sql = "SELECT pair_id, rows, cols, data, config, F, E, H";
  if (schema_.has_two_view_pose) sql += ", qvec, tvec";
  sql += " FROM two_view_geometries WHERE pair_id = ?";
  Statement statement(*this, sql);
  statement.Bind(1,
                 static_cast<int64_t>(ImagePairToPairId(image_id1, image_id2)));
  if (!statement.Step()) return false;
  *geometry = ReadTwoViewGeometryRow(&statement);
  if (SwapImagePair(image_id1, image_id2)) *geometry = geometry->Inverse();
  return true;
}

std::vector<TwoViewGeometry> Database::ReadAllTwoViewGeometries() const {
  std::string sql = "SELECT pair_id, rows, cols, data, config, F, E, H";
  if (schema_.has_two_view_pose) sql += ", qvec, tvec";
  sql += " FROM two_view_geometries ORDER BY pair_id";
  Statement statement(*this, sql);
  std::vector<TwoViewGeometry> geometries;
  while (statement.Step()) {
    geometries.push_back(ReadTwoViewGeometryRow(&statement));
  }
  return geometries;
}

std::string CameraIntrinsicsProblem(const Camera& camera) {
  if (!CameraHasValidParams(camera)) {
    return "has " + std::to_string(camera.params.size()) + " parameters, " +
           CameraModelIdToName(camera.model_id) + " has " +
           std::to_string(CameraModelNumParams(camera.model_id));
  }
  for (size_t k = 0; k < camera.params.size(); ++k) {
    if (!std::isfinite(camera.params[k])) {
      return "parameter " + std::to_string(k + 1) + " (of " +
             CameraModelParamsInfo(camera.model_id) + ") is not finite";
    }
  }
  const double width = static_cast<double>(camera.width);
  const double height = static_cast<double>(camera.height);
  for (const int k : CameraModelFocalLengthIdxs(camera.model_id)) {
    std::ostringstream value;
    value << camera.params[k];
    if (!(camera.params[k] > 0)) {
      return "focal length " + value.str() + " is not positive";
    }
    // Beyond these no pose can be estimated (a field of view of almost 180
    // degrees or of a micro-degree); the solvers would fail with no hint.
    const double ratio = camera.params[k] / std::max(width, height);
    if (ratio < 1e-3 || ratio > 1e5) {
      return "focal length " + value.str() + " px is implausible for a " +
             std::to_string(camera.width) + " x " +
             std::to_string(camera.height) +
             " image (expected 0.001 to 100000 times its larger side)";
    }
  }
  const std::vector<int> pp = CameraModelPrincipalPointIdxs(camera.model_id);
  const double cx = camera.params[pp[0]];
  const double cy = camera.params[pp[1]];
  if (cx < -width || cx > 2 * width || cy < -height || cy > 2 * height) {
    std::ostringstream value;
    value << "principal point (" << cx << ", " << cy << ") is far outside the "
          << camera.width << " x " << camera.height << " image";
    return value.str();
  }
  if (CameraModelExtraParamsIdxs(camera.model_id).empty()) return "";
  // Distortion: the viewing-ray angle must grow from the principal point to
  // the farthest image corner, and the corner's angle must be within a factor
  // 4 of the undistorted (pinhole) one; a real lens, even a fisheye, is.
  Camera pinhole = camera;
  for (const int k : CameraModelExtraParamsIdxs(camera.model_id)) {
    pinhole.params[k] = 0;
  }
  const double corner_x = cx < width / 2 ? width : 0;
  const double corner_y = cy < height / 2 ? height : 0;
  constexpr int kNumSamples = 32;
  double previous = 0;
  for (int s = 1; s <= kNumSamples; ++s) {
    const double a = static_cast<double>(s) / kNumSamples;
    const Eigen::Vector2d pixel(cx + a * (corner_x - cx),
                                cy + a * (corner_y - cy));
    const Eigen::Vector3d ray = CameraImageToRay(camera, pixel);
    const double angle = std::atan2(ray.head<2>().norm(), ray.z());
    if (!std::isfinite(angle) || angle < previous - 1e-9) {
      return "distortion parameters make the lens fold back inside the image "
             "(no real lens does)";
    }
    previous = angle;
    if (s == kNumSamples) {
      const Eigen::Vector3d ideal = CameraImageToRay(pinhole, pixel);
      const double ideal_angle = std::atan2(ideal.head<2>().norm(), ideal.z());
      if (ideal_angle > 0 &&
          (angle > 4 * ideal_angle || angle < ideal_angle / 4)) {
        std::ostringstream value;
        value << "distortion parameters change the corner's viewing angle "
                 "from "
              << ideal_angle * 180 / M_PI << " to " << angle * 180 / M_PI
              << " deg (no real lens does)";
        return value.str();
      }
    }
  }
  return "";
}

Camera ResetCameraIntrinsics(const Camera& camera) {
  Camera reset = camera;
  reset.params.assign(CameraModelNumParams(camera.model_id), 0.0);
  const double focal =
      1.2 * static_cast<double>(std::max(camera.width, camera.height));
  for (const int k : CameraModelFocalLengthIdxs(camera.model_id)) {
    reset.params[k] = focal;
  }
  const std::vector<int> pp = CameraModelPrincipalPointIdxs(camera.model_id);
  reset.params[pp[0]] = static_cast<double>(camera.width) / 2;
  reset.params[pp[1]] = static_cast<double>(camera.height) / 2;
  reset.has_prior_focal_length = false;
  return reset;
}

namespace {

// Logs a warning about the database and keeps it for the summary.
void Warn(const std::string& message, DatabaseContents* contents) {
  LOG(WARNING) << contents->path << ": " << message;
  contents->warnings.push_back(message);
}

// Reads the images, whose names identify them in the model (and in COLMAP):
// unique, non-empty, without a NUL byte (it ends a name in images.bin), each
// on a camera of the cameras table. Returns the cameras the images use.
std::set<camera_t> ReadImages(const Database& database,
                              DatabaseContents* contents) {
  const std::string& path = contents->path;
  std::set<camera_t> used_cameras;
  std::map<std::string, image_t> names;
  for (DatabaseImage& image : database.ReadAllImages()) {
    const std::string id = "image " + std::to_string(image.image_id);
    if (image.name.empty()) {
      throw InputError(path, id + " has no name (NULL or empty)");
    }
    if (image.name.find('\0') != std::string::npos) {
      throw InputError(path, id + "'s name contains a NUL byte");
    }
    const auto [named, inserted] = names.emplace(image.name, image.image_id);
    if (!inserted) {
      throw InputError(path, "images " + std::to_string(named->second) +
                                 " and " + std::to_string(image.image_id) +
                                 " have the same name '" + image.name +
                                 "' (the images table's UNIQUE constraint "
                                 "on name is missing?)");
    }
    if (contents->cameras.count(image.camera_id) == 0) {
      throw InputError(path, "image " + std::to_string(image.image_id) + " '" +
                                 image.name + "' refers to camera " +
                                 std::to_string(image.camera_id) +
                                 ", which is not in the cameras table");
    }
    used_cameras.insert(image.camera_id);
    contents->images[image.image_id] = std::move(image);
  }
  return used_cameras;
}

// Intrinsics of the cameras the images use: an invalid camera gives a
// wrong model (mirrored, rotated) rather than none, so it is an error
// unless the options reset it.
void CheckUsedCameras(const std::set<camera_t>& used_cameras,
                      const DatabaseReadOptions& options,
                      DatabaseContents* contents) {
  for (const camera_t camera_id : used_cameras) {
    Camera& camera = contents->cameras.at(camera_id);
    const std::string problem = CameraIntrinsicsProblem(camera);
    if (problem.empty()) continue;
    const std::string what = "camera " + std::to_string(camera_id) + " (" +
                             CameraModelIdToName(camera.model_id) + "): ";
    if (!options.reset_invalid_cameras) {
      throw InputError(contents->path,
                       what + problem +
                           "; fix the camera, or pass "
                           "--Mapper.reset_invalid_cameras 1 to start "
                           "it from a default focal and refine it");
    }
    camera = ResetCameraIntrinsics(camera);
    contents->reset_cameras.push_back(camera_id);
    Warn(
        what + problem + "; reset to focal " +
            std::to_string(
                camera.params[CameraModelFocalLengthIdxs(camera.model_id)[0]]) +
            " px, centred principal point, no distortion",
        contents);
  }
}

// Reads the keypoints of the images. Returns, per image that has any, which
// keypoints are invalid: non-finite or outside the image, never an
// observation.
std::map<image_t, std::vector<char>> ReadCheckedKeypoints(
    const Database& database, DatabaseContents* contents) {
  std::map<image_t, std::vector<char>> invalid_keypoints;
  for (const auto& [image_id, image] : contents->images) {
    std::vector<float> scales;
    FeatureKeypoints keypoints = database.ReadKeypoints(image_id, &scales);
    const Camera& camera = contents->cameras.at(image.camera_id);
    // COLMAP's keypoints lie in [0, width] x [0, height]; one pixel of slack.
    const double max_x = static_cast<double>(camera.width) + 1;
    const double max_y = static_cast<double>(camera.height) + 1;
    std::vector<char>* invalid = nullptr;
    int num_nonfinite = 0, num_outside = 0;
    for (size_t k = 0; k < keypoints.size(); ++k) {
      const double x = keypoints[k].x(), y = keypoints[k].y();
      const bool nonfinite = !std::isfinite(x) || !std::isfinite(y);
      const bool outside =
          !nonfinite && (x < -1 || y < -1 || x > max_x || y > max_y);
      if (!nonfinite && !outside) continue;
      if (invalid == nullptr) {
        invalid = &invalid_keypoints[image_id];
        invalid->assign(keypoints.size(), 0);
      }
      (*invalid)[k] = 1;
      nonfinite ? ++num_nonfinite : ++num_outside;
    }
    if (num_nonfinite > 0) {
      contents->num_keypoints_invalid["non-finite keypoint"] += num_nonfinite;
      Warn("image " + std::to_string(image_id) + " '" + image.name +
               "': " + std::to_string(num_nonfinite) +
               " non-finite keypoints, never used as observations",
           contents);
    }
    if (num_outside > 0) {
      contents->num_keypoints_invalid["keypoint outside the image"] +=
          num_outside;
      Warn("image " + std::to_string(image_id) + " '" + image.name +
               "': " + std::to_string(num_outside) + " keypoints outside the " +
               std::to_string(camera.width) + " x " +
               std::to_string(camera.height) +
               " image, never used as observations",
           contents);
    }
    contents->keypoints[image_id] = std::move(keypoints);
    if (!scales.empty()) {
      contents->keypoint_scales[image_id] = std::move(scales);
    }
  }
  return invalid_keypoints;
}

// What a pair's messages call it, its images in the order stored.
std::string GeometryName(const TwoViewGeometry& geometry) {
  return "two_view_geometries of pair (" + std::to_string(geometry.image_id1) +
         ", " + std::to_string(geometry.image_id2) + ")";
}

// Reads the verified pairs: self-pairs skipped, pairs stored with their
// images swapped turned round (and merged when also stored in COLMAP's
// order).
std::map<image_pair_t, TwoViewGeometry> ReadPairs(const Database& database,
                                                  DatabaseContents* contents) {
  std::map<image_pair_t, TwoViewGeometry> pairs;
  for (TwoViewGeometry& geometry : database.ReadAllTwoViewGeometries()) {
    const std::string what = GeometryName(geometry);
    if (geometry.image_id1 == geometry.image_id2) {
      ++contents->num_pairs_dropped["image paired with itself"];
      Warn(what + ": an image paired with itself, skipped", contents);
      continue;
    }
    const bool swapped = geometry.image_id1 > geometry.image_id2;
    if (swapped) geometry = geometry.Inverse();
    const image_pair_t pair_id =
        ImagePairToPairId(geometry.image_id1, geometry.image_id2);
    if (pairs.count(pair_id) > 0) {
      ++contents->num_pairs_dropped["stored in both orders"];
      Warn(what +
               ": the pair is stored in both orders; the row in COLMAP's "
               "order (smaller image id first) is used",
           contents);
      if (!swapped) pairs[pair_id] = std::move(geometry);
      continue;
    }
    pairs.emplace(pair_id, std::move(geometry));
  }
  return pairs;
}

// Adds the pairs to the contents: each must be between known images with
// matches in range of their keypoints; matches on invalid keypoints are
// dropped.
void AddPairs(const std::map<image_t, std::vector<char>>& invalid_keypoints,
              std::map<image_pair_t, TwoViewGeometry>* pairs,
              DatabaseContents* contents) {
  const std::string& path = contents->path;
  for (auto& [pair_id, geometry] : *pairs) {
    const std::string what = GeometryName(geometry);
    const auto keypoints1 = contents->keypoints.find(geometry.image_id1);
    const auto keypoints2 = contents->keypoints.find(geometry.image_id2);
    if (keypoints1 == contents->keypoints.end() ||
        keypoints2 == contents->keypoints.end()) {
      throw InputError(path, what +
                                 ": refers to an image that is not in "
                                 "the images table");
    }
    for (const FeatureMatch& match : geometry.inlier_matches) {
      if (match.point2D_idx1 >= keypoints1->second.size() ||
          match.point2D_idx2 >= keypoints2->second.size()) {
        throw InputError(
            path, what + ": match (" + std::to_string(match.point2D_idx1) +
                      ", " + std::to_string(match.point2D_idx2) +
                      ") is out of range of the images' " +
                      std::to_string(keypoints1->second.size()) + " and " +
                      std::to_string(keypoints2->second.size()) + " keypoints");
      }
    }
    const auto invalid1 = invalid_keypoints.find(geometry.image_id1);
    const auto invalid2 = invalid_keypoints.find(geometry.image_id2);
    if (invalid1 != invalid_keypoints.end() ||
        invalid2 != invalid_keypoints.end()) {
      const size_t before = geometry.inlier_matches.size();
      auto& matches = geometry.inlier_matches;
      matches.erase(
          std::remove_if(matches.begin(), matches.end(),
                         [&](const FeatureMatch& match) {
                           return (invalid1 != invalid_keypoints.end() &&
                                   invalid1->second[match.point2D_idx1]) ||
                                  (invalid2 != invalid_keypoints.end() &&
                                   invalid2->second[match.point2D_idx2]);
                         }),
          matches.end());
      contents->num_matches_dropped_invalid_keypoint +=
          static_cast<int>(before - matches.size());
    }
    contents->two_view_geometries.push_back(std::move(geometry));
  }
}

}  // namespace

DatabaseContents ReadDatabase(const std::string& path,
                              const DatabaseReadOptions& options) {
  Database database(path, options);
  DatabaseContents contents;
  contents.path = path;
  contents.schema = database.Schema();
  for (Camera& camera : database.ReadAllCameras()) {
    contents.cameras[camera.camera_id] = std::move(camera);
  }
  const std::set<camera_t> used_cameras = ReadImages(database, &contents);
  CheckUsedCameras(used_cameras, options, &contents);
  const std::map<image_t, std::vector<char>> invalid_keypoints =
      ReadCheckedKeypoints(database, &contents);
  std::map<image_pair_t, TwoViewGeometry> pairs =
      ReadPairs(database, &contents);
  AddPairs(invalid_keypoints, &pairs, &contents);
  contents.num_matches = database.ReadNumMatches();
  database.CheckUnchanged();
  return contents;
}

}  // namespace colmap_irav4
