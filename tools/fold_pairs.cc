// The fold check's per-pair evidence on a mapped model, for studying how
// much of its predicted overlap a verified pair matches:
//   fold_pairs DATABASE MODEL_DIR [GT_MODEL_DIR]
// prints one line per verified pair the model agrees with and predicts to
// overlap in both directions: ids, inliers, predicted co-visible points (both
// directions), inliers per predicted point, a verdict ("true" when the
// pair's measured rotation agrees with the ground truth, "false" for a
// mirror-twin or random pair, "-" without a ground truth), whether the pair
// is one of the predicted overlapping pairs (1/0) and "weak" or "strong";
// the fold report goes to stderr.

#include <iomanip>
#include <iostream>
#include <set>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/io/database.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/pipeline/component_mapper.h"
#include "colmap_irav4/refinement/fold_detection.h"

using namespace colmap_irav4;

int main(int argc, char** argv) {
  if (argc != 3 && argc != 4) {
    std::cerr << "usage: " << argv[0] << " DATABASE MODEL_DIR [GT_MODEL_DIR]\n";
    return 2;
  }
  try {
    const DatabaseContents database = ReadDatabase(argv[1]);
    const Reconstruction model = ReadReconstruction(argv[2]);
    Reconstruction truth;
    const bool has_truth = argc == 4;
    if (has_truth) truth = ReadReconstruction(argv[3]);
    const FoldEvidence evidence = BuildModelFoldEvidence(database, model);
    FoldDetectionOptions options;
    const FoldReport report = DetectFold(options, model, evidence);
    std::cerr << report.Describe() << "\n";
    std::map<std::pair<image_t, image_t>, const PairEvidence*> by_pair;
    for (const PairEvidence& pair : evidence.pairs)
      by_pair[{pair.image_id1, pair.image_id2}] = &pair;
    for (const PairSupport& support : report.pair_support) {
      std::string kind = "-";
      if (has_truth) {
        // Truth and database share image ids (the generator's).
        const PairEvidence& pair =
            *by_pair.at({support.image_id1, support.image_id2});
        const Eigen::Matrix3d R1 =
            truth.images.at(support.image_id1)
                .cam_from_world.rotation.toRotationMatrix();
        const Eigen::Matrix3d R2 =
            truth.images.at(support.image_id2)
                .cam_from_world.rotation.toRotationMatrix();
        kind = AngularDistanceDeg(pair.R, R2 * R1.transpose()) < 5 ? "true"
                                                                   : "false";
      }
      std::cout << support.image_id1 << " " << support.image_id2 << " "
                << support.num_inliers << " " << std::fixed
                << std::setprecision(1) << support.num_predicted12 << " "
                << support.num_predicted21 << " " << std::setprecision(3)
                << support.ratio << " " << kind << " " << support.predicted
                << " " << (support.weak ? "weak" : "strong") << "\n";
    }
  } catch (const std::exception& error) {
    std::cerr << "ERROR: " << error.what() << "\n";
    return 1;
  }
  return 0;
}
