#pragma once

// The mapper's pose priors: where they are read from and how they are
// reported (io/pose_priors.h reads and converts them; positioning and
// bundle adjustment use them).

#include <string>

#include "colmap_irav4/io/database.h"
#include "colmap_irav4/io/pose_priors.h"
#include "colmap_irav4/pipeline/global_mapper.h"

namespace colmap_irav4 {

// Reads the priors of options.pose_prior_path (when given) or of the
// database into database->pose_priors (nothing with use_pose_priors off),
// logs what was read and skipped, and returns it (without the priors
// themselves): source, frame, counts, skipped ones.
LocalPosePriors LoadPosePriors(const GlobalMapperOptions& options,
                               DatabaseContents* database);

// summary.json's "pose_priors" object.
std::string PosePriorsJson(const LocalPosePriors& priors);

}  // namespace colmap_irav4
