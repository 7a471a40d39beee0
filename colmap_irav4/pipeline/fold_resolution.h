#pragma once

// Fold check and resolution around the mapping of one component: map, test
// the model for a fold (refinement/fold_detection.h); if folded, remove the
// pairs that explain the conflict and map again (rotation averaging,
// positioning and refinement redone on what remains); where that does not
// resolve it, split the component at the weakest cut into separate models
// rather than write a folded one; where no cut is found, write the model
// with a warning (never silently).

#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "colmap_irav4/io/database.h"
#include "colmap_irav4/pipeline/global_mapper.h"
#include "colmap_irav4/refinement/fold_detection.h"
#include "colmap_irav4/util/run_summary.h"
#include "colmap_irav4/view_graph/view_graph.h"

namespace colmap_irav4 {

// The database's evidence about the pairs of `images`: every verified
// geometry (with its inlier count), every pair the raw matches table records
// as tried, and the view graph's measured rotations.
FoldEvidence BuildFoldEvidence(const DatabaseContents& database,
                               const std::vector<ImagePairGeometry>& pairs,
                               const std::set<image_t>& images);

// The stages of one mapping attempt: up to positioning (nullptr, with the
// reason in *failure, when no model results), then the refinement (bundle
// adjustment, retriangulation, final filtering; false when it gave up).
struct ComponentStages {
  std::function<std::unique_ptr<GlobalMapper>(
      const std::vector<image_t>& images,
      const std::vector<ImagePairGeometry>& pairs, const std::string& prefix,
      std::string* failure)>
      position;
  std::function<bool(GlobalMapper* mapper, std::string* failure)> refine;
};

// GlobalMapper's stages on `database` with `cameras` (both must outlive the
// returned functions' use).
ComponentStages GlobalMapperStages(const GlobalMapperOptions& options,
                                   const DatabaseContents& database,
                                   const std::map<camera_t, Camera>& cameras);

struct FoldCheckedModel {
  std::unique_ptr<GlobalMapper> mapper;  // refined
  bool checked = false;
  FoldReport fold;  // of the model as written
  // "clean", "resolved (...)", "split", "folded (...)".
  std::string outcome;
  // The fold checks (after positioning and after refinement) of this model's
  // attempt, for its report.
  std::vector<StageReport> stages;
};

// Maps one component: positions it, checks it for a fold (after positioning:
// a folded attempt is not refined; again after refinement) and resolves a
// fold as described above. Returns the models (empty if none, with the
// reason in *failure). Notes for summary.json go to *notes.
std::vector<FoldCheckedModel> MapComponentWithFoldCheck(
    const FoldResolutionOptions& options, int min_model_size,
    const FoldEvidence& evidence, const std::vector<image_t>& images,
    const std::vector<ImagePairGeometry>& pairs, const std::string& prefix,
    const ComponentStages& stages, std::vector<std::string>* notes,
    std::string* failure);

}  // namespace colmap_irav4
