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
#include "colmap_irav4/scene/pose_prior.h"
#include "colmap_irav4/scene/types.h"

struct sqlite3;

namespace colmap_irav4 {

// An image row of the database, with the pose prior of its
// images.prior_q*/prior_t* columns when there is one (COLMAP <= 3.9; the
// pose_priors table of 3.10+ is read by io/pose_priors.h).
struct DatabaseImage {
  image_t image_id = kInvalidImageId;
  std::string name;
  camera_t camera_id = kInvalidCameraId;
  bool has_prior_rotation = false;
  Eigen::Vector4d prior_qvec = Eigen::Vector4d(1, 0, 0, 0);
  bool has_prior_position = false;
  // images.prior_t* (COLMAP 3.8/3.9's feature extractor writes EXIF GPS
  // latitude, longitude, altitude there).
  Eigen::Vector3d prior_tvec = Eigen::Vector3d::Zero();
};

// Which COLMAP schema a database has (detected from its tables and columns).
struct DatabaseSchema {
  bool has_matches_table = false;
  bool has_two_view_pose = false;        // two_view_geometries.qvec/tvec (3.8+)
  bool has_image_prior_columns = false;  // images.prior_* (<= 3.9)
  bool has_pose_priors_table = false;    // 3.10+
  bool has_rigs_table = false;           // 4.x: rigs, frames, frame_data
  bool has_frames_table = false;
  bool has_frame_data_table = false;
  // "COLMAP <= 3.7", "COLMAP 3.8/3.9", "COLMAP 3.10+" or "COLMAP 4.x".
  std::string Description() const;
};

// How a database is opened and what is done with suspicious records.
struct DatabaseReadOptions {
  // How long to wait for a writer holding the database locked before failing
  // (milliseconds).
  int busy_timeout_ms = 10000;
  // Cameras with invalid intrinsics (non-positive or non-finite focal, non-
  // finite parameters, implausible distortion) are an error; with this flag
  // they are reset to a sane start (focal 1.2 * max(width, height), centred
  // principal point, no distortion) and treated as having no prior focal,
  // so that calibration / bundle adjustment refine them.
  bool reset_invalid_cameras = false;
};

// How the file was opened (see Database).
enum class DatabaseOpenMode {
  kLocking,    // SQLite's normal locking, read-only connection
  kImmutable,  // immutable=1: WAL-mode file without a -wal (nothing to merge)
};

// Read-only access to a COLMAP database, in one read transaction (every
// reader sees one consistent snapshot), and without ever creating a file next
// to the database:
//  - rollback-journal databases are opened read-only with SQLite's normal
//    locking: committed content is read, a writer holding the lock is waited
//    for (busy_timeout_ms), then the read fails with a clear message; a
//    read-only connection creates no journal;
//  - WAL databases with a -wal file and its -shm are opened read-only with
//    normal locking: committed WAL content is seen, uncommitted never; the
//    existing -shm is used, nothing is created;
//  - WAL databases without a -wal file hold everything in the main file, but a
//    non-immutable open would create -wal and -shm files (SQLite needs the
//    wal-index even to read), so they are opened with immutable=1; the file's
//    size and mtime are checked again after reading (a writer that started
//    meanwhile makes the read fail instead of returning a torn snapshot);
//  - a WAL database with a non-empty -wal but no -shm cannot be read without
//    creating a -shm: a clear error says how to recover it.
// Every problem with the file (missing, not SQLite, locked, missing table or
// column, malformed blob, unknown camera model, dangling ids) throws
// InputError naming the file and the record.
class Database {
 public:
  explicit Database(const std::string& path,
                    const DatabaseReadOptions& options = DatabaseReadOptions());
  ~Database();
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  const std::string& Path() const { return path_; }
  const DatabaseSchema& Schema() const { return schema_; }
  DatabaseOpenMode OpenMode() const { return open_mode_; }
  // Throws InputError if an immutable-mode file changed (or grew a -wal)
  // since it was opened: what was read may be torn.
  void CheckUnchanged() const;
  // The read-only connection, inside this object's read transaction, for
  // readers of optional tables kept in their own files (io/pose_priors.cc).
  sqlite3* Connection() const { return db_; }

  std::vector<Camera> ReadAllCameras() const;
  std::vector<DatabaseImage> ReadAllImages() const;
  // Keypoints of one image (x, y); empty if the image has no keypoints row.
  // With `scales`, also each keypoint's scale in pixels (KeypointScale), or
  // none (empty) when the table stores positions only (2 columns).
  FeatureKeypoints ReadKeypoints(image_t image_id,
                                 std::vector<float>* scales = nullptr) const;
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
  DatabaseOpenMode open_mode_ = DatabaseOpenMode::kLocking;
  int busy_timeout_ms_ = 0;
  // Size and modification time at opening (immutable mode's check).
  int64_t opened_size_ = 0;
  int64_t opened_mtime_ns_ = 0;
};

// Why a camera's intrinsics cannot be used ("" when they can): non-finite
// parameters, non-positive focal length, principal point far outside the
// image, or a distortion no real lens has (the viewing-ray angle is not
// increasing from the principal point to the farthest corner, or the corner's
// angle differs from the undistorted one by more than a factor 4).
std::string CameraIntrinsicsProblem(const Camera& camera);
// The camera with a sane start: focal 1.2 * max(width, height), principal
// point at the centre, zero distortion, no prior focal.
Camera ResetCameraIntrinsics(const Camera& camera);

// The scale in pixels of a keypoint stored as `cols` floats at `data`: the
// third float of 4 (x, y, scale, orientation), the mean length of the affine
// shape's columns of 6 (x, y, a11, a12, a21, a22; COLMAP's
// FeatureKeypoint::ComputeScale), 0 (unknown) of 2.
float KeypointScale(const float* data, int cols);

// Everything of a database the mapper uses, validated for consistency
// (cameras of images exist, match indices within the keypoints).
struct DatabaseContents {
  std::string path;
  DatabaseSchema schema;
  std::map<camera_t, Camera> cameras;
  std::map<image_t, DatabaseImage> images;
  std::map<image_t, FeatureKeypoints> keypoints;
  // Each keypoint's scale in pixels, for the images whose keypoints store a
  // shape (4 or 6 columns); bundle adjustment weighs observations by it.
  std::map<image_t, std::vector<float>> keypoint_scales;
  // Database orientation (image_id1 < image_id2), ordered by pair id.
  std::vector<TwoViewGeometry> two_view_geometries;
  // Raw match counts per pair id (for inlier ratios); may be empty.
  std::map<image_pair_t, int> num_matches;
  // Verified pairs skipped while reading, by reason ("image paired with
  // itself", "stored in both orders").
  std::map<std::string, int> num_pairs_dropped;
  // Keypoints unusable as observations, by reason ("non-finite keypoint",
  // "keypoint outside the image"), and the inlier matches dropped because
  // they use one. Those keypoints stay (indices are kept) but never reach a
  // track, positioning or bundle adjustment.
  std::map<std::string, int> num_keypoints_invalid;
  int num_matches_dropped_invalid_keypoint = 0;
  // Cameras reset by DatabaseReadOptions::reset_invalid_cameras.
  std::vector<camera_t> reset_cameras;
  // One line per warning (also logged), for the run summary.
  std::vector<std::string> warnings;
  // Pose priors in one metric frame, by image id: not read by ReadDatabase
  // but set by the mapper (pipeline/pose_prior_setup.h) from the database's
  // pose priors or a text file.
  PosePriors pose_priors;
};

// Reads and validates everything (one read transaction). Throws InputError
// naming the file, the record and the problem.
DatabaseContents ReadDatabase(
    const std::string& path,
    const DatabaseReadOptions& options = DatabaseReadOptions());

}  // namespace colmap_irav4
