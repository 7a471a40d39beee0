#pragma once

#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/geometry/two_view_geometry.h"
#include "colmap_irav4/scene/camera.h"
#include "colmap_irav4/scene/features.h"
#include "colmap_irav4/scene/types.h"

struct sqlite3;

namespace colmap_irav4 {

// An image row of the database, with its pose prior when there is one
// (COLMAP <= 3.9: images.prior_q*/prior_t* columns; 3.10+: pose_priors table,
// position only).
struct DatabaseImage {
  image_t image_id = kInvalidImageId;
  std::string name;
  camera_t camera_id = kInvalidCameraId;
  bool has_prior_rotation = false;
  Eigen::Vector4d prior_qvec = Eigen::Vector4d(1, 0, 0, 0);
  bool has_prior_position = false;
  // cam_from_world translation (images.prior_t*) or, from pose_priors, the
  // camera centre in the prior's coordinate system.
  Eigen::Vector3d prior_tvec = Eigen::Vector3d::Zero();
};

// Which COLMAP schema a database has (detected from its tables and columns).
struct DatabaseSchema {
  bool has_matches_table = false;
  bool has_two_view_pose = false;      // two_view_geometries.qvec/tvec (3.8+)
  bool has_image_prior_columns = false;  // images.prior_* (<= 3.9)
  bool has_pose_priors_table = false;    // 3.10+
  bool has_rigs_table = false;           // 4.x: rigs, frames, frame_data
  bool has_frames_table = false;
  bool has_frame_data_table = false;
  // "COLMAP <= 3.7", "COLMAP 3.8/3.9", "COLMAP 3.10+" or "COLMAP 4.x".
  std::string Description() const;
};

// Read-only access to a COLMAP database. The file is opened with
// SQLITE_OPEN_READONLY in immutable URI mode, so that nothing, not even the
// header's change counter or a -shm/-wal file, is written. Every problem with
// the file (missing, not SQLite, missing table or column, malformed blob,
// unknown camera model, dangling ids) throws InputError naming the file.
class Database {
 public:
  explicit Database(const std::string& path);
  ~Database();
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  const std::string& Path() const { return path_; }
  const DatabaseSchema& Schema() const { return schema_; }

  std::vector<Camera> ReadAllCameras() const;
  std::vector<DatabaseImage> ReadAllImages() const;
  // Keypoints of one image (x, y); empty if the image has no keypoints row.
  FeatureKeypoints ReadKeypoints(image_t image_id) const;
  // Number of keypoints per image (rows column), without reading the blobs.
  std::map<image_t, int> ReadNumKeypoints() const;
  // Raw (unverified) matches, oriented image_id1 -> image_id2.
  FeatureMatches ReadMatches(image_t image_id1, image_t image_id2) const;
  // Number of raw matches per pair id (rows column); empty without a matches
  // table or when it was emptied (e.g. the bundled example database).
  std::map<image_pair_t, int> ReadNumMatches() const;
  // The verified geometry of a pair, oriented image_id1 -> image_id2 (inverted
  // if the database stores it the other way round). False if absent.
  bool ReadTwoViewGeometry(image_t image_id1, image_t image_id2,
                           TwoViewGeometry* geometry) const;
  // Every verified pair, in the database's orientation (image_id1 <
  // image_id2), ordered by pair id.
  std::vector<TwoViewGeometry> ReadAllTwoViewGeometries() const;

 private:
  struct Statement;
  TwoViewGeometry ReadTwoViewGeometryRow(Statement* statement) const;
  std::set<std::string> TableColumns(const std::string& table) const;
  [[noreturn]] void Fail(const std::string& problem) const;

  std::string path_;
  sqlite3* db_ = nullptr;
  DatabaseSchema schema_;
};

// Everything of a database the mapper uses, validated for consistency
// (cameras of images exist, match indices within the keypoints).
struct DatabaseContents {
  std::string path;
  DatabaseSchema schema;
  std::map<camera_t, Camera> cameras;
  std::map<image_t, DatabaseImage> images;
  std::map<image_t, FeatureKeypoints> keypoints;
  // Database orientation (image_id1 < image_id2), ordered by pair id.
  std::vector<TwoViewGeometry> two_view_geometries;
  // Raw match counts per pair id (for inlier ratios); may be empty.
  std::map<image_pair_t, int> num_matches;
};

DatabaseContents ReadDatabase(const std::string& path);

}  // namespace colmap_irav4
