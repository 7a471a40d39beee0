#pragma once

// Writes a new COLMAP 3.8 database (the schema COLMAP 3.8's
// Database::CreateTables creates), e.g. for synthetic scenes. Everything goes
// into one transaction in a temporary file beside the target, renamed onto
// the target by Commit(): the output is complete or absent.

#include <string>

#include "colmap_irav4/geometry/two_view_geometry.h"
#include "colmap_irav4/scene/camera.h"
#include "colmap_irav4/scene/features.h"
#include "colmap_irav4/scene/types.h"

struct sqlite3;
struct sqlite3_stmt;

namespace colmap_irav4 {

// COLMAP 3.8's schema, as its Database::CreateTables writes it (SQL).
const char* Colmap38Schema();

class DatabaseWriter {
 public:
  // Throws InputError if `path` exists or cannot be created.
  explicit DatabaseWriter(const std::string& path);
  // Removes the temporary file unless Commit() succeeded.
  ~DatabaseWriter();
  DatabaseWriter(const DatabaseWriter&) = delete;
  DatabaseWriter& operator=(const DatabaseWriter&) = delete;

  void WriteCamera(const Camera& camera);
  void WriteImage(image_t image_id, const std::string& name,
                  camera_t camera_id);
  // Two floats (x, y) per keypoint, as COLMAP reads them; with scales (one
  // per keypoint) four: x, y, scale, orientation 0.
  void WriteKeypoints(image_t image_id, const FeatureKeypoints& keypoints,
                      const std::vector<float>& scales = {});
  // Raw matches oriented image_id1 -> image_id2 (swapped into the database's
  // order image_id1 < image_id2 if needed).
  void WriteMatches(image_t image_id1, image_t image_id2,
                    const FeatureMatches& matches);
  // Inverted into the database's order if needed. F, E, H row-major; qvec and
  // tvec written only if has_pose (else zero, as COLMAP 3.8 by default).
  void WriteTwoViewGeometry(const TwoViewGeometry& geometry);
  void Commit();

 private:
  void Exec(const std::string& sql);
  sqlite3_stmt* Prepare(const std::string& sql);
  void Step(sqlite3_stmt* statement, const std::string& what);
  [[noreturn]] void Fail(const std::string& problem) const;

  std::string path_;
  std::string temp_path_;
  sqlite3* db_ = nullptr;
  sqlite3_stmt* camera_stmt_ = nullptr;
  sqlite3_stmt* image_stmt_ = nullptr;
  sqlite3_stmt* keypoints_stmt_ = nullptr;
  sqlite3_stmt* matches_stmt_ = nullptr;
  sqlite3_stmt* geometry_stmt_ = nullptr;
  bool committed_ = false;
};

}  // namespace colmap_irav4
