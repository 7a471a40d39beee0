#pragma once

// Pose priors (GPS positions, gravity) where COLMAP users have them, and
// their conversion into one metric frame:
//  - the database: COLMAP 3.10-3.12's pose_priors table (image_id, position,
//    coordinate_system, and from 3.11 position_covariance), COLMAP 4.x's
//    (corr_data_id, corr_sensor_id, corr_sensor_type, position,
//    position_covariance, gravity, coordinate_system), or COLMAP 3.8/3.9's
//    images.prior_tx/ty/tz columns, which their feature extractor fills with
//    EXIF GPS (latitude, longitude, altitude);
//  - a text file in the format of COLMAP's `model_aligner --ref_images_path`:
//    one `IMAGE_NAME X Y Z` line per image (latitude, longitude, altitude
//    with the WGS84 flag), optionally followed by a gravity direction
//    `GX GY GZ` (down, in the camera frame); '#' starts a comment.
// Positions are blobs of 3 doubles, covariances of 9 (column-major), gravity
// of 3; coordinate_system -1 unknown (used as Cartesian), 0 WGS84, 1
// Cartesian. WGS84 positions are converted to a local east-north-up frame
// whose origin is the median of the priors' latitudes, longitudes and
// altitudes. Missing, NaN or out-of-range priors are skipped and counted,
// never an error; a file that cannot be read or parsed is (InputError naming
// the file and the line).

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "colmap_irav4/geometry/gps.h"
#include "colmap_irav4/io/database.h"
#include "colmap_irav4/scene/pose_prior.h"

namespace colmap_irav4 {

enum class PriorCoordinateSystem { kUnknown = -1, kWgs84 = 0, kCartesian = 1 };

// A prior as stored, before conversion.
struct StoredPosePrior {
  std::string image_name;
  // Latitude, longitude (deg), altitude (m) for WGS84; NaN when absent.
  Eigen::Vector3d position = Eigen::Vector3d::Constant(PosePrior::kNaN);
  // In metres^2 (COLMAP: in the Cartesian frame even for WGS84 positions).
  Eigen::Matrix3d position_covariance =
      Eigen::Matrix3d::Constant(PosePrior::kNaN);
  Eigen::Vector3d gravity = Eigen::Vector3d::Constant(PosePrior::kNaN);
  PriorCoordinateSystem coordinate_system = PriorCoordinateSystem::kUnknown;
};

struct StoredPosePriors {
  // Where they come from, e.g. "pose_priors table (COLMAP 4.x)".
  std::string source;
  std::vector<StoredPosePrior> priors;
  // Records left out, by reason (e.g. "prior of a non-camera sensor").
  std::map<std::string, int> num_skipped;
};

// The database's priors: its pose_priors table if it has one (3.10+), else
// its images.prior_tx/ty/tz columns (3.8/3.9: WGS84 from EXIF); none
// (source "") otherwise. Throws InputError for a blob of the wrong size.
StoredPosePriors ReadDatabasePosePriors(const Database& database);

// A text file (format above); `wgs84`: X Y Z are latitude, longitude,
// altitude. Throws InputError naming the file and line if it cannot be read
// or a line is not NAME followed by 3 or 6 numbers ("nan" is a number: that
// prior is skipped).
StoredPosePriors ReadPosePriorText(const std::string& path, bool wgs84);

// Priors in one metric frame, by image id.
struct LocalPosePriors {
  std::string source;
  PosePriors priors;
  // The frame: east-north-up at `enu_origin` when the positions were WGS84,
  // else the priors' own Cartesian frame.
  bool is_enu = false;
  Wgs84 enu_origin;
  int num_positions = 0;
  int num_gravity = 0;
  // Priors (or parts of them) left out, by reason.
  std::map<std::string, int> num_skipped;
  // Whether the source holds no prior at all: no position kept, and every
  // image skipped only for having none (COLMAP 3.8's image columns of a
  // capture without GPS). Nothing is wrong then, so nothing is warned.
  bool NoneStored() const;
  // One line per kind of skipped prior ("12 priors skipped: NaN position");
  // none when NoneStored().
  std::vector<std::string> Warnings() const;
};

// Converts stored priors into one frame: matches names to `image_ids`
// (unknown names skipped), keeps the majority's coordinate system (unknown
// counts as Cartesian; priors of the other skipped), drops NaN or
// out-of-range positions and WGS84 (0, 0) fixes, invalid covariances (not
// symmetric positive definite: the default is used) and zero or non-finite
// gravity, and converts WGS84 to east-north-up.
LocalPosePriors ConvertPosePriors(
    const StoredPosePriors& stored,
    const std::map<std::string, image_t>& image_ids);

// How a database holds pose priors: COLMAP 3.8/3.9's images.prior_tx/ty/tz
// (WGS84 only, no covariance or gravity), 3.11's pose_priors table (position,
// coordinate_system, position_covariance) or 4.x's (with gravity).
enum class PosePriorSchema { kColmap38, kColmap311, kColmap4 };
// "colmap38", "colmap311", "colmap4"; throws InputError for another name.
PosePriorSchema PosePriorSchemaFromName(const std::string& name);

// Adds priors (by image id, positions in their coordinate system) to an
// existing database of the images, in one transaction, in COLMAP's layout of
// `schema` (the table created as COLMAP creates it). For synthetic scenes
// and tests; throws InputError if the database cannot be written.
void WritePosePriorsToDatabase(
    const std::string& path, PosePriorSchema schema,
    const std::map<image_t, StoredPosePrior>& priors);

// The small file written beside each model ("prior_frame.txt"): what frame
// its coordinates are in and, for east-north-up, the WGS84 origin.
std::string PriorFrameText(const LocalPosePriors& priors);

}  // namespace colmap_irav4
