#pragma once

// Fold check and resolution around the mapping of one component: map, test
// the model for a fold (refinement/fold_detection.h); if folded, remove the
// pairs that explain the conflict and map again (rotation averaging,
// positioning and refinement redone on what remains); where that does not
// resolve it, split the component at the weakest cut into separate models
// rather than write a folded one; where no cut is found, write the model
// with a warning (never silently).

#include <functional>
#include <set>
#include <string>
#include <vector>

#include "colmap_irav4/io/database.h"
#include "colmap_irav4/pipeline/global_mapper.h"
#include "colmap_irav4/refinement/fold_detection.h"
#include "colmap_irav4/view_graph/view_graph.h"

namespace colmap_irav4 {

class OptionManager;


void AddFoldResolutionOptions(OptionManager* manager,
                              FoldResolutionOptions* options);

// The database's evidence about the pairs of `images`: every verified
// geometry (with its inlier count), every pair the raw matches table records
// as tried, and the view graph's measured rotations.
FoldEvidence BuildFoldEvidence(const DatabaseContents& database,
                               const std::vector<ImagePairGeometry>& pairs,
                               const std::set<image_t>& images);

// Maps `images` / `pairs` into a model; false (with the reason) if none.
typedef std::function<bool(const std::vector<image_t>& images,
                           const std::vector<ImagePairGeometry>& pairs,
                           const std::string& prefix,
                           Reconstruction* reconstruction,
                           ComponentReport* report, std::string* failure)>
    MapComponentFunction;

struct MappedModel {
  Reconstruction reconstruction;
  ComponentReport report;
};

// Maps one component through `map_component`, checks the result and
// resolves a fold as described above. Returns the models (empty if none);
// each report carries its fold figures. Notes for summary.json go to
// *notes; *failure holds the reason when no model results.
std::vector<MappedModel> MapComponentWithFoldCheck(
    const FoldResolutionOptions& options, int min_model_size,
    const FoldEvidence& evidence, const std::vector<image_t>& images,
    const std::vector<ImagePairGeometry>& pairs, const std::string& prefix,
    const MapComponentFunction& map_component, std::vector<std::string>* notes,
    std::string* failure);

}  // namespace colmap_irav4
