#include "colmap_irav4/io/pose_priors.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <memory>
#include <set>
#include <sstream>

#include <sqlite3.h>
#include <Eigen/Dense>

#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

// COLMAP 4's SensorType::CAMERA (-1 INVALID, 0 CAMERA, 1 IMU).
constexpr int64_t kCameraSensorType = 0;
// An image row of COLMAP 3.8/3.9 without a GPS fix.
constexpr char kNoPosition[] = "no position (NULL)";

using StatementPtr = std::unique_ptr<sqlite3_stmt, int (*)(sqlite3_stmt*)>;

StatementPtr Prepare(const Database& database, const std::string& sql) {
  sqlite3_stmt* statement = nullptr;
  if (sqlite3_prepare_v2(database.Connection(), sql.c_str(), -1, &statement,
                         nullptr) != SQLITE_OK) {
    sqlite3_finalize(statement);
    throw InputError(database.Path(),
                     std::string("SQLite error: ") +
                         sqlite3_errmsg(database.Connection()) + " (in '" +
                         sql + "')");
  }
  return StatementPtr(statement, sqlite3_finalize);
}

bool Step(const Database& database, sqlite3_stmt* statement) {
  const int rc = sqlite3_step(statement);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  throw InputError(database.Path(), std::string("SQLite error: ") +
                                        sqlite3_errmsg(database.Connection()));
}

std::set<std::string> Columns(const Database& database,
                              const std::string& table) {
  std::set<std::string> columns;
  StatementPtr statement =
      Prepare(database, "PRAGMA table_info(" + table + ")");
  while (Step(database, statement.get())) {
    columns.insert(
        reinterpret_cast<const char*>(sqlite3_column_text(statement.get(), 1)));
  }
  return columns;
}

// A blob of `size` doubles into `values` (left NaN when NULL or empty, as
// COLMAP writes an absent matrix); a blob of another size is an error.
void ReadDoubles(const Database& database, sqlite3_stmt* statement, int column,
                 const std::string& what, int size, double* values) {
  const int bytes = sqlite3_column_bytes(statement, column);
  if (sqlite3_column_type(statement, column) == SQLITE_NULL || bytes == 0) {
    return;
  }
  if (bytes != size * static_cast<int>(sizeof(double))) {
    throw InputError(database.Path(),
                     what + " blob has " + std::to_string(bytes) +
                         " bytes, expected " +
                         std::to_string(size * sizeof(double)) + " (" +
                         std::to_string(size) + " doubles)");
  }
  std::memcpy(values, sqlite3_column_blob(statement, column), bytes);
}

PriorCoordinateSystem ToCoordinateSystem(int64_t value) {
  if (value == 0) return PriorCoordinateSystem::kWgs84;
  if (value == 1) return PriorCoordinateSystem::kCartesian;
  return PriorCoordinateSystem::kUnknown;
}

double Median(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2,
                   values.end());
  return values[values.size() / 2];
}

}  // namespace

StoredPosePriors ReadDatabasePosePriors(const Database& database) {
  StoredPosePriors stored;
  std::map<int64_t, std::string> names;
  std::map<int64_t, int64_t> camera_of_image;
  for (const DatabaseImage& image : database.ReadAllImages()) {
    names[image.image_id] = image.name;
    camera_of_image[image.image_id] = image.camera_id;
  }
  if (!database.Schema().has_pose_priors_table) {
    if (!database.Schema().has_image_prior_columns) return stored;
    // COLMAP 3.8/3.9: the feature extractor writes EXIF GPS here (NULL or
    // NaN, which SQLite stores as NULL, without a fix).
    stored.source = "images.prior_tx/ty/tz (COLMAP 3.8/3.9, WGS84)";
    StatementPtr statement = Prepare(
        database,
        "SELECT name, prior_tx, prior_ty, prior_tz FROM images ORDER BY "
        "image_id");
    while (Step(database, statement.get())) {
      StoredPosePrior prior;
      prior.image_name = reinterpret_cast<const char*>(
          sqlite3_column_text(statement.get(), 0));
      bool complete = true;
      for (int k = 0; k < 3; ++k) {
        if (sqlite3_column_type(statement.get(), 1 + k) == SQLITE_NULL) {
          complete = false;
        } else {
          prior.position[k] = sqlite3_column_double(statement.get(), 1 + k);
        }
      }
      if (!complete) {
        ++stored.num_skipped[kNoPosition];
        continue;
      }
      prior.coordinate_system = PriorCoordinateSystem::kWgs84;
      stored.priors.push_back(prior);
    }
    return stored;
  }
  const std::set<std::string> columns = Columns(database, "pose_priors");
  const bool colmap4 = columns.count("corr_data_id") > 0;
  const std::string id_column = colmap4 ? "corr_data_id" : "image_id";
  for (const std::string& column :
       {id_column, std::string("position"), std::string("coordinate_system")}) {
    if (columns.count(column) == 0) {
      throw InputError(database.Path(),
                       "table 'pose_priors' has no column '" + column + "'");
    }
  }
  const bool has_covariance = columns.count("position_covariance") > 0;
  const bool has_gravity = columns.count("gravity") > 0;
  const bool has_sensor = colmap4 && columns.count("corr_sensor_id") &&
                          columns.count("corr_sensor_type");
  stored.source = colmap4          ? "pose_priors table (COLMAP 4.x)"
                  : has_covariance ? "pose_priors table (COLMAP 3.11/3.12)"
                                   : "pose_priors table (COLMAP 3.10)";
  std::string sql = "SELECT " + id_column + ", position, coordinate_system";
  sql += has_covariance ? ", position_covariance" : ", NULL";
  sql += has_gravity ? ", gravity" : ", NULL";
  sql += has_sensor ? ", corr_sensor_id, corr_sensor_type" : ", NULL, NULL";
  sql += " FROM pose_priors ORDER BY " + id_column;
  StatementPtr statement = Prepare(database, sql);
  std::set<int64_t> seen;
  while (Step(database, statement.get())) {
    sqlite3_stmt* row = statement.get();
    const int64_t image_id = sqlite3_column_int64(row, 0);
    if (has_sensor && sqlite3_column_int64(row, 6) != kCameraSensorType) {
      ++stored.num_skipped["prior of a non-camera sensor"];
      continue;
    }
    const auto name = names.find(image_id);
    if (name == names.end()) {
      ++stored.num_skipped["prior of an image not in the database"];
      continue;
    }
    if (has_sensor &&
        sqlite3_column_int64(row, 5) != camera_of_image[image_id]) {
      ++stored.num_skipped["prior of another camera than its image's"];
      continue;
    }
    if (!seen.insert(image_id).second) {
      ++stored.num_skipped["second prior of an image"];
      continue;
    }
    const std::string what =
        "pose_priors of image " + std::to_string(image_id) + ": ";
    StoredPosePrior prior;
    prior.image_name = name->second;
    ReadDoubles(database, row, 1, what + "position", 3, prior.position.data());
    prior.coordinate_system = ToCoordinateSystem(sqlite3_column_int64(row, 2));
    ReadDoubles(database, row, 3, what + "position_covariance", 9,
                prior.position_covariance.data());
    ReadDoubles(database, row, 4, what + "gravity", 3, prior.gravity.data());
    stored.priors.push_back(prior);
  }
  return stored;
}

StoredPosePriors ReadPosePriorText(const std::string& path, bool wgs84) {
  std::ifstream file(path);
  if (!file) {
    throw InputError(path, std::string("cannot open pose prior file: ") +
                               std::strerror(errno));
  }
  StoredPosePriors stored;
  stored.source = path + (wgs84 ? " (WGS84)" : " (Cartesian)");
  std::string line;
  int line_number = 0;
  while (std::getline(file, line)) {
    ++line_number;
    const size_t comment = line.find('#');
    if (comment != std::string::npos) line.resize(comment);
    std::istringstream stream(line);
    StoredPosePrior prior;
    if (!(stream >> prior.image_name)) continue;  // blank
    std::vector<double> values;
    std::string token;
    while (stream >> token) {
      char* end = nullptr;
      const double value = std::strtod(token.c_str(), &end);
      if (end == token.c_str() || *end != '\0') {
        throw InputError(path, "line " + std::to_string(line_number) + ": '" +
                                   token + "' is not a number");
      }
      values.push_back(value);
    }
    if (values.size() != 3 && values.size() != 6) {
      throw InputError(path,
                       "line " + std::to_string(line_number) +
                           ": expected IMAGE_NAME X Y Z [GX GY GZ], got " +
                           std::to_string(values.size()) + " numbers");
    }
    prior.position = Eigen::Vector3d(values[0], values[1], values[2]);
    if (values.size() == 6) {
      prior.gravity = Eigen::Vector3d(values[3], values[4], values[5]);
    }
    prior.coordinate_system = wgs84 ? PriorCoordinateSystem::kWgs84
                                    : PriorCoordinateSystem::kCartesian;
    stored.priors.push_back(prior);
  }
  if (file.bad()) throw InputError(path, "read error");
  return stored;
}

bool LocalPosePriors::NoneStored() const {
  return priors.empty() && num_skipped.size() == 1 &&
         num_skipped.count(kNoPosition) == 1;
}

std::vector<std::string> LocalPosePriors::Warnings() const {
  std::vector<std::string> warnings;
  if (NoneStored()) return warnings;
  for (const auto& [reason, count] : num_skipped) {
    warnings.push_back("pose priors (" + source +
                       "): " + std::to_string(count) + " skipped: " + reason);
  }
  return warnings;
}

LocalPosePriors ConvertPosePriors(
    const StoredPosePriors& stored,
    const std::map<std::string, image_t>& image_ids) {
  LocalPosePriors local;
  local.source = stored.source;
  local.num_skipped = stored.num_skipped;
  // The majority's coordinate system (unknown counts as Cartesian).
  int num_wgs84 = 0, num_cartesian = 0;
  for (const StoredPosePrior& prior : stored.priors) {
    if (!prior.position.allFinite()) continue;
    ++(prior.coordinate_system == PriorCoordinateSystem::kWgs84
           ? num_wgs84
           : num_cartesian);
  }
  local.is_enu = num_wgs84 > num_cartesian;

  struct Kept {
    image_t image_id;
    const StoredPosePrior* prior;
    bool has_position;
  };
  std::vector<Kept> kept;
  std::vector<double> latitudes, longitudes, altitudes;
  std::set<image_t> seen;
  for (const StoredPosePrior& prior : stored.priors) {
    const auto id = image_ids.find(prior.image_name);
    if (id == image_ids.end()) {
      ++local.num_skipped["image name not in the database"];
      continue;
    }
    if (!seen.insert(id->second).second) {
      ++local.num_skipped["second prior of an image"];
      continue;
    }
    bool has_position = prior.position.allFinite();
    if (!has_position) {
      ++local.num_skipped["no position or a NaN coordinate"];
    } else if ((prior.coordinate_system == PriorCoordinateSystem::kWgs84) !=
               local.is_enu) {
      ++local.num_skipped[local.is_enu ? "Cartesian position among WGS84 ones"
                                       : "WGS84 position among Cartesian ones"];
      has_position = false;
    } else if (local.is_enu) {
      const Wgs84 geodetic{prior.position[0], prior.position[1],
                           prior.position[2]};
      if (!IsValidWgs84(geodetic)) {
        ++local.num_skipped["WGS84 position out of range"];
        has_position = false;
      } else if (geodetic.latitude == 0 && geodetic.longitude == 0) {
        ++local.num_skipped["WGS84 position 0, 0 (no GPS fix)"];
        has_position = false;
      } else {
        latitudes.push_back(geodetic.latitude);
        longitudes.push_back(geodetic.longitude);
        altitudes.push_back(geodetic.altitude);
      }
    }
    kept.push_back({id->second, &prior, has_position});
  }
  if (!latitudes.empty()) {
    local.enu_origin =
        Wgs84{Median(latitudes), Median(longitudes), Median(altitudes)};
  }
  const EnuFrame enu(local.enu_origin);
  for (const Kept& item : kept) {
    PosePrior prior;
    if (item.has_position) {
      const Eigen::Vector3d& position = item.prior->position;
      prior.position = local.is_enu
                           ? enu.ToEnu({position[0], position[1], position[2]})
                           : position;
      const Eigen::Matrix3d& covariance = item.prior->position_covariance;
      if (covariance.allFinite() && !covariance.isZero()) {
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance);
        if ((covariance - covariance.transpose()).norm() <=
                1e-9 * covariance.norm() &&
            eigen.eigenvalues().minCoeff() > 0) {
          prior.position_covariance = covariance;
        } else {
          ++local.num_skipped
                ["covariance not symmetric positive definite (default used)"];
        }
      }
      ++local.num_positions;
    }
    const Eigen::Vector3d& gravity = item.prior->gravity;
    if (gravity.allFinite()) {
      if (gravity.norm() > 1e-6) {
        prior.gravity = gravity.normalized();
        ++local.num_gravity;
      } else {
        ++local.num_skipped["zero gravity vector"];
      }
    }
    if (prior.HasPosition() || prior.HasGravity()) {
      local.priors[item.image_id] = prior;
    }
  }
  return local;
}

PosePriorSchema PosePriorSchemaFromName(const std::string& name) {
  if (name == "colmap38") return PosePriorSchema::kColmap38;
  if (name == "colmap311") return PosePriorSchema::kColmap311;
  if (name == "colmap4") return PosePriorSchema::kColmap4;
  throw InputError("pose prior schema '" + name +
                   "': expected colmap38, colmap311 or colmap4");
}

void WritePosePriorsToDatabase(
    const std::string& path, PosePriorSchema schema,
    const std::map<image_t, StoredPosePrior>& priors) {
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr) !=
      SQLITE_OK) {
    const std::string message = db ? sqlite3_errmsg(db) : "out of memory";
    sqlite3_close(db);
    throw InputError(path, "cannot open for writing (" + message + ")");
  }
  std::unique_ptr<sqlite3, int (*)(sqlite3*)> owner(db, sqlite3_close);
  auto fail = [&](const std::string& what) {
    sqlite3_exec(db, "ROLLBACK", nullptr, nullptr, nullptr);
    throw InputError(path,
                     "cannot write " + what + " (" + sqlite3_errmsg(db) + ")");
  };
  auto exec = [&](const std::string& sql) {
    if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr) != SQLITE_OK)
      fail(sql);
  };
  exec("BEGIN");
  // The tables as COLMAP 3.11 and 4.1 create them.
  if (schema == PosePriorSchema::kColmap311) {
    exec(
        "CREATE TABLE IF NOT EXISTS pose_priors"
        "   (image_id                   INTEGER  PRIMARY KEY  NOT NULL,"
        "    position                   BLOB,"
        "    coordinate_system          INTEGER               NOT NULL,"
        "    position_covariance        BLOB,"
        "FOREIGN KEY(image_id) REFERENCES images(image_id) ON DELETE "
        "CASCADE);");
  } else if (schema == PosePriorSchema::kColmap4) {
    exec(
        "CREATE TABLE IF NOT EXISTS pose_priors"
        "   (pose_prior_id              INTEGER  PRIMARY KEY  NOT NULL,"
        "    corr_data_id               INTEGER               NOT NULL,"
        "    corr_sensor_id             INTEGER               NOT NULL,"
        "    corr_sensor_type           INTEGER               NOT NULL,"
        "    position                   BLOB,"
        "    position_covariance        BLOB,"
        "    gravity                    BLOB,"
        "    coordinate_system          INTEGER               NOT NULL);"
        "CREATE UNIQUE INDEX IF NOT EXISTS pose_prior_data_assignment ON "
        "   pose_priors(corr_data_id, corr_sensor_id, corr_sensor_type);");
  }
  const std::string sql =
      schema == PosePriorSchema::kColmap38
          ? "UPDATE images SET prior_tx = ?2, prior_ty = ?3, prior_tz = ?4 "
            "WHERE image_id = ?1"
      : schema == PosePriorSchema::kColmap311
          ? "INSERT INTO pose_priors(image_id, position, coordinate_system, "
            "position_covariance) VALUES (?1, ?5, ?6, ?7)"
          : "INSERT INTO pose_priors(corr_data_id, corr_sensor_id, "
            "corr_sensor_type, position, position_covariance, gravity, "
            "coordinate_system) VALUES (?1, (SELECT camera_id FROM images "
            "WHERE image_id = ?1), 0, ?5, ?7, ?8, ?6)";
  sqlite3_stmt* raw = nullptr;
  if (sqlite3_prepare_v2(db, sql.c_str(), -1, &raw, nullptr) != SQLITE_OK) {
    fail(sql);
  }
  StatementPtr statement(raw, sqlite3_finalize);
  // NaN matrices (absent) as NULL, as COLMAP reads them back as absent.
  auto bind_matrix = [&](int index, const double* values, int size) {
    bool finite = true;
    for (int k = 0; k < size; ++k) finite &= std::isfinite(values[k]);
    if (finite) {
      sqlite3_bind_blob(raw, index, values, size * sizeof(double),
                        SQLITE_TRANSIENT);
    } else {
      sqlite3_bind_null(raw, index);
    }
  };
  for (const auto& [image_id, prior] : priors) {
    sqlite3_bind_int64(raw, 1, image_id);
    for (int k = 0; k < 3; ++k) {
      sqlite3_bind_double(raw, 2 + k, prior.position[k]);
    }
    bind_matrix(5, prior.position.data(), 3);
    sqlite3_bind_int64(raw, 6, static_cast<int>(prior.coordinate_system));
    bind_matrix(7, prior.position_covariance.data(), 9);
    bind_matrix(8, prior.gravity.data(), 3);
    if (sqlite3_step(raw) != SQLITE_DONE) {
      fail("the prior of image " + std::to_string(image_id));
    }
    sqlite3_reset(raw);
    sqlite3_clear_bindings(raw);
  }
  statement.reset();
  exec("COMMIT");
}

std::string PriorFrameText(const LocalPosePriors& priors) {
  std::ostringstream text;
  text << std::setprecision(12);
  text << "# Frame of this model's coordinates (colmap_irav4 mapper, pose "
          "priors from "
       << priors.source << ")\n";
  if (priors.is_enu) {
    text << "# Metres east, north, up of the WGS84 origin below "
            "(latitude, longitude in degrees, altitude in metres)\n";
    text << "FRAME ENU\n";
    text << "ORIGIN_WGS84 " << priors.enu_origin.latitude << ' '
         << priors.enu_origin.longitude << ' ' << priors.enu_origin.altitude
         << '\n';
  } else {
    text << "# The priors' own Cartesian frame (their units)\n";
    text << "FRAME CARTESIAN\n";
  }
  return text.str();
}

}  // namespace colmap_irav4
