// libFuzzer target: decoding of the database's blobs and records. The input
// is split into the fields of one camera, two images' keypoints and one
// verified pair (rows, cols, config, data, F/E/H/qvec/tvec blobs), written
// into a small COLMAP 3.8 database, and read with ReadDatabase. Every
// malformed record must end in InputError (or a warning), never a crash.

#include <sqlite3.h>

#include <cstdint>
#include <cstring>
#include <filesystem>

#include "colmap_irav4/io/database.h"
#include "colmap_irav4/util/error.h"
#include "tests/fuzz/fuzz_utils.h"

namespace {

int64_t Int(const std::string& bytes) {
  int64_t value = 0;
  std::memcpy(&value, bytes.data(), std::min<size_t>(8, bytes.size()));
  return value;
}

void Exec(sqlite3* db, const char* sql) {
  sqlite3_exec(db, sql, nullptr, nullptr, nullptr);
}

void Insert(sqlite3* db, const char* sql,
            const std::vector<std::pair<bool, std::string>>& values) {
  sqlite3_stmt* stmt = nullptr;
  if (sqlite3_prepare_v2(db, sql, -1, &stmt, nullptr) != SQLITE_OK) return;
  for (size_t k = 0; k < values.size(); ++k) {
    const int index = static_cast<int>(k) + 1;
    if (values[k].first) {
      sqlite3_bind_int64(stmt, index, Int(values[k].second));
    } else {
      sqlite3_bind_blob(stmt, index, values[k].second.data(),
                        static_cast<int>(values[k].second.size()),
                        SQLITE_TRANSIENT);
    }
  }
  sqlite3_step(stmt);
  sqlite3_finalize(stmt);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace colmap_irav4;
  // camera: model, width, height, params; keypoints 1 and 2: rows, cols,
  // data; pair: pair_id, rows, cols, config, data, F, E, H, qvec, tvec.
  const std::vector<std::string> p = fuzz::SplitInput(data, size, 20);
  if (p.size() != 20) return 0;
  const std::string path = fuzz::ScratchDir() + "/fuzz.db";
  std::filesystem::remove(path);
  sqlite3* db = nullptr;
  if (sqlite3_open(path.c_str(), &db) != SQLITE_OK) return 0;
  Exec(db, "PRAGMA journal_mode=OFF; PRAGMA synchronous=OFF;");
  Exec(db,
       "CREATE TABLE cameras (camera_id INTEGER PRIMARY KEY, model INTEGER, "
       "width INTEGER, height INTEGER, params BLOB, prior_focal_length "
       "INTEGER);"
       "CREATE TABLE images (image_id INTEGER PRIMARY KEY, name TEXT, "
       "camera_id INTEGER, prior_qw REAL, prior_qx REAL, prior_qy REAL, "
       "prior_qz REAL, prior_tx REAL, prior_ty REAL, prior_tz REAL);"
       "CREATE TABLE keypoints (image_id INTEGER PRIMARY KEY, rows INTEGER, "
       "cols INTEGER, data BLOB);"
       "CREATE TABLE matches (pair_id INTEGER PRIMARY KEY, rows INTEGER, "
       "cols INTEGER, data BLOB);"
       "CREATE TABLE two_view_geometries (pair_id INTEGER PRIMARY KEY, rows "
       "INTEGER, cols INTEGER, data BLOB, config INTEGER, F BLOB, E BLOB, H "
       "BLOB, qvec BLOB, tvec BLOB);"
       "INSERT INTO images VALUES (1, 'a.jpg', 1, NULL, NULL, NULL, NULL, "
       "NULL, NULL, NULL), (2, 'b.jpg', 1, 1, 0, 0, 0, 1, 2, 3);");
  Insert(
      db, "INSERT INTO cameras VALUES (1, ?, ?, ?, ?, ?)",
      {{true, p[0]}, {true, p[1]}, {true, p[2]}, {false, p[3]}, {true, p[4]}});
  Insert(db, "INSERT INTO keypoints VALUES (1, ?, ?, ?)",
         {{true, p[5]}, {true, p[6]}, {false, p[7]}});
  Insert(db, "INSERT INTO keypoints VALUES (2, ?, ?, ?)",
         {{true, p[8]}, {true, p[9]}, {false, p[10]}});
  Insert(db,
         "INSERT INTO two_view_geometries VALUES (?, ?, ?, ?, ?, ?, ?, ?, "
         "?, ?)",
         {{true, p[11]},
          {true, p[12]},
          {true, p[13]},
          {false, p[14]},
          {true, p[15]},
          {false, p[16]},
          {false, p[17]},
          {false, p[18]},
          {false, p[19].substr(0, p[19].size() / 2)},
          {false, p[19].substr(p[19].size() / 2)}});
  sqlite3_close(db);
  try {
    const DatabaseContents contents = ReadDatabase(path);
    for (const TwoViewGeometry& geometry : contents.two_view_geometries) {
      geometry.Inverse();
    }
  } catch (const InputError&) {
  }
  return 0;
}
