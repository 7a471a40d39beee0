#include "colmap_irav4/pipeline/pose_prior_setup.h"

#include <sstream>

#include <glog/logging.h>

#include "colmap_irav4/util/run_summary.h"

namespace colmap_irav4 {

LocalPosePriors LoadPosePriors(const GlobalMapperOptions& options,
                               DatabaseContents* database) {
  database->pose_priors.clear();
  if (!options.use_pose_priors) return LocalPosePriors();
  const StoredPosePriors stored =
      options.pose_prior_path.empty()
          ? ReadDatabasePosePriors(Database(database->path))
          : ReadPosePriorText(options.pose_prior_path,
                              options.pose_prior_wgs84);
  std::map<std::string, image_t> image_ids;
  for (const auto& [image_id, image] : database->images) {
    image_ids[image.name] = image_id;
  }
  LocalPosePriors priors = ConvertPosePriors(stored, image_ids);
  for (const std::string& warning : priors.Warnings()) {
    LOG(WARNING) << warning;
  }
  if (priors.NoneStored()) {
    LOG(INFO) << "No pose priors: " << priors.source
              << " holds no position (a capture without GPS)";
  }
  if (!priors.priors.empty()) {
    LOG(INFO) << "Pose priors from " << priors.source << ": "
              << priors.num_positions << " positions, " << priors.num_gravity
              << " gravity directions; frame: "
              << (priors.is_enu ? "east-north-up (m) at WGS84 " : "Cartesian")
              << (priors.is_enu
                      ? std::to_string(priors.enu_origin.latitude) + ", " +
                            std::to_string(priors.enu_origin.longitude) + ", " +
                            std::to_string(priors.enu_origin.altitude)
                      : std::string());
    if (priors.num_gravity > 0) {
      LOG(INFO) << "Gravity priors set the model's up axis when it is placed "
                   "in the priors' frame and constrain the camera rotations "
                   "in bundle adjustment (rotation averaging itself does not "
                   "use them)";
    }
  }
  database->pose_priors = std::move(priors.priors);
  priors.priors.clear();
  return priors;
}

std::string PosePriorsJson(const LocalPosePriors& priors) {
  std::ostringstream out;
  out << "{\"source\": " << JsonString(priors.source)
      << ", \"num_positions\": " << priors.num_positions
      << ", \"num_gravity\": " << priors.num_gravity << ", \"frame\": "
      << JsonString(priors.num_positions == 0 ? "none"
                    : priors.is_enu           ? "ENU"
                                              : "CARTESIAN");
  if (priors.is_enu) {
    out << ", \"enu_origin_wgs84\": [" << JsonNumber(priors.enu_origin.latitude)
        << ", " << JsonNumber(priors.enu_origin.longitude) << ", "
        << JsonNumber(priors.enu_origin.altitude) << "]";
  }
  out << ", \"skipped\": {";
  bool first = true;
  for (const auto& [reason, count] : priors.num_skipped) {
    out << (first ? "" : ", ") << JsonString(reason) << ": " << count;
    first = false;
  }
  out << "}}";
  return out.str();
}

}  // namespace colmap_irav4
