// How the fold check's cut divides a folded model's images, against the
// truth, for studying the fold resolution on a scene:
//   fold_cut_eval DATABASE MODEL_DIR GT_MODEL_DIR [--Fold.* VALUE ...]
// MODEL_DIR: a model the fold check calls folded (e.g. the mapper's with
// --Fold.resolve 0 --Mapper.skip_bundle_adjustment 1: positioned, points
// triangulated, as the first fold check sees it). Each of its images is
// labelled by the truth: "right" (rotation error after the robust similarity
// alignment under 90 deg) or "folded" (over 90 deg: at its mirror twin's
// place). Prints the fold report, the signed graph's pairs by label (trusted
// pairs pull, missing and weak predicted pairs push: how many join two right
// images, two folded ones, or one of each), and each side of FoldCut by
// label; the cut is right when one side holds the right images and the
// other the folded ones.

#include <iomanip>
#include <iostream>
#include <set>

#include "colmap_irav4/eval/model_alignment.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/io/database.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/pipeline/component_mapper.h"
#include "colmap_irav4/pipeline/option_registration.h"
#include "colmap_irav4/refinement/fold_detection.h"
#include "colmap_irav4/util/error.h"
#include "colmap_irav4/util/option_manager.h"

using namespace colmap_irav4;

namespace {

// Pairs by the labels of their two images: both right, both folded, mixed.
struct LabelCounts {
  int right = 0;
  int folded = 0;
  int mixed = 0;
  int unlabelled = 0;
  void Add(int label1, int label2) {
    if (label1 < 0 || label2 < 0) {
      ++unlabelled;
    } else if (label1 != label2) {
      ++mixed;
    } else {
      (label1 == 0 ? right : folded) += 1;
    }
  }
  std::string Describe() const {
    return std::to_string(right) + " right-right, " + std::to_string(folded) +
           " folded-folded, " + std::to_string(mixed) + " across the fold" +
           (unlabelled ? ", " + std::to_string(unlabelled) + " unlabelled"
                       : "");
  }
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4 || argc % 2 != 0) {
    std::cerr << "usage: " << argv[0]
              << " DATABASE MODEL_DIR GT_MODEL_DIR [--Fold.* VALUE ...]\n";
    return 2;
  }
  try {
    FoldResolutionOptions fold;
    {
      OptionManager flags("fold_cut_eval");
      AddFoldResolutionOptions(&flags, &fold);
      std::vector<char*> flag_argv = {argv[0]};
      for (int k = 4; k < argc; ++k) flag_argv.push_back(argv[k]);
      flags.Parse(static_cast<int>(flag_argv.size()), flag_argv.data());
    }
    const FoldDetectionOptions& options = fold.detection;
    const DatabaseContents database = ReadDatabase(argv[1]);
    const Reconstruction model = ReadReconstruction(argv[2]);
    const Reconstruction truth = ReadReconstruction(argv[3]);

    // Labels: 0 right, 1 folded, -1 not in the truth.
    PoseComparison comparison;
    if (!ComparePoses(PosesByName(model), PosesByName(truth),
                      SimilarityRansacOptions(), &comparison)) {
      throw InputError(argv[2], "cannot be aligned with the truth");
    }
    std::map<std::string, int> label_of_name;
    for (size_t k = 0; k < comparison.names.size(); ++k) {
      label_of_name[comparison.names[k]] =
          comparison.rotation_errors_deg[k] > 90 ? 1 : 0;
    }
    std::map<image_t, int> label;
    int num_folded = 0;
    for (const auto& [image_id, image] : model.images) {
      const auto it = label_of_name.find(image.name);
      label[image_id] = it == label_of_name.end() ? -1 : it->second;
      num_folded += label[image_id] == 1;
    }
    std::cout << "model: " << model.images.size() << " images, " << num_folded
              << " folded (rotation error over 90 deg after alignment)\n";

    const FoldEvidence evidence = BuildModelFoldEvidence(database, model);
    const FoldReport report = DetectFold(options, model, evidence);
    std::cout << "fold report: " << report.Describe() << "\n";

    LabelCounts missing;
    for (const auto& [a, b] : report.missing_pairs) {
      missing.Add(label[a], label[b]);
    }
    LabelCounts weak;
    LabelCounts strong;
    for (const PairSupport& support : report.pair_support) {
      if (!support.predicted) continue;
      (support.weak ? weak : strong)
          .Add(label[support.image_id1], label[support.image_id2]);
    }
    LabelCounts suspect;
    for (const auto& [a, b] : report.suspect_pairs)
      suspect.Add(label[a], label[b]);
    std::cout << "missing pairs: " << missing.Describe() << "\n"
              << "weak predicted pairs: " << weak.Describe() << "\n"
              << "strong predicted pairs: " << strong.Describe() << "\n"
              << "suspect pairs: " << suspect.Describe() << "\n";

    // Every verified pair the cut may weigh, by whether the model agrees
    // with its rotation and whether the truth does (a true pair, or a
    // mirror-twin or random one).
    LabelCounts pair_counts[2][2];  // [model agrees][true pair]
    for (const PairEvidence& pair : evidence.pairs) {
      if (!pair.has_rotation || pair.num_inliers < options.min_num_matches) {
        continue;
      }
      const auto rotation = [&](const Reconstruction& r, image_t id) {
        return r.images.at(id).cam_from_world.rotation.toRotationMatrix();
      };
      const bool agrees =
          AngularDistanceDeg(pair.R,
                             rotation(model, pair.image_id2) *
                                 rotation(model, pair.image_id1).transpose()) <=
          options.max_rotation_error_deg;
      const bool is_true =
          truth.images.count(pair.image_id1) &&
          truth.images.count(pair.image_id2) &&
          AngularDistanceDeg(
              pair.R, rotation(truth, pair.image_id2) *
                          rotation(truth, pair.image_id1).transpose()) < 5;
      pair_counts[agrees][is_true].Add(label[pair.image_id1],
                                       label[pair.image_id2]);
    }
    for (const int agrees : {1, 0}) {
      for (const int is_true : {1, 0}) {
        std::cout << (is_true ? "true" : "false") << " pairs the model "
                  << (agrees ? "agrees with" : "contradicts") << ": "
                  << pair_counts[agrees][is_true].Describe() << "\n";
      }
    }

    const auto [side1, side2] = FoldCut(options, model, evidence, report);
    for (const std::vector<image_t>* side : {&side1, &side2}) {
      int counts[3] = {0, 0, 0};  // right, folded, unlabelled
      for (const image_t image_id : *side) {
        const int l = label[image_id];
        ++counts[l < 0 ? 2 : l];
      }
      std::cout << "cut side " << (side == &side1 ? 1 : 2) << ": "
                << side->size() << " images, " << counts[0] << " right, "
                << counts[1] << " folded, " << counts[2] << " unlabelled\n";
    }
  } catch (const std::exception& error) {
    std::cerr << "ERROR: " << error.what() << "\n";
    return 1;
  }
  return 0;
}
