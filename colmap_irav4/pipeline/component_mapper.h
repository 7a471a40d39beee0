#pragma once

// The mapping of one connected component with its fold check and
// resolution: map (GlobalMapper::Solve, whose fold checks test the model,
// refinement/fold_detection.h); if folded, re-orient the images across the
// weakest cut, else remove the suspect pairs, and map again (rotation
// averaging, positioning and refinement redone on what remains); where that
// does not resolve it, split the component at the cut into separate models
// rather than write a folded one; where no cut is found, write the model
// with a warning (never silently). A clean model that is not one rigid
// piece is mapped again with its parts joined where the pairs across them
// are confirmed (pipeline/part_merge.h); every model is then written as its
// rigid parts (refinement/model_rigidity.h).

#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "colmap_irav4/io/database.h"
#include "colmap_irav4/pipeline/global_mapper.h"
#include "colmap_irav4/refinement/fold_detection.h"
#include "colmap_irav4/view_graph/view_graph.h"

namespace colmap_irav4 {

// The database's evidence about the pairs of `images`: every verified
// geometry (with its inlier count), every pair the raw matches table records
// as tried, and the view graph's measured rotations.
FoldEvidence BuildFoldEvidence(const DatabaseContents& database,
                               const std::vector<ImagePairGeometry>& pairs,
                               const std::set<image_t>& images);

// The evidence about the view graph's pairs (default options) among the
// images of `model`: for the tools that study a written model's fold check.
FoldEvidence BuildModelFoldEvidence(const DatabaseContents& database,
                                    const Reconstruction& model);

// `pairs` without those across the cut (one image in `side`, the other in
// the model and not in `side`) that the model agrees with (within
// max_rotation_error_deg): across a fold, those are the false pairs that
// made it, and the ones it contradicts are the true pairs. With
// drop_contradicted_within, also without the pairs on one side that the
// model contradicts: only the pairs the model with `side` turned agrees with
// remain (a false pair between two turned cameras, or two right ones, can
// fold the model again elsewhere).
std::vector<ImagePairGeometry> PairsReorientedAcrossCut(
    const std::vector<ImagePairGeometry>& pairs,
    const Reconstruction& reconstruction, const std::vector<image_t>& side,
    double max_rotation_error_deg, bool drop_contradicted_within = false);

// One model of a component.
struct ComponentModel {
  std::unique_ptr<GlobalMapper> mapper;  // solved (refined)
  // Written flagged folded (the fold check's last report may say otherwise:
  // a model written as folded stays flagged).
  bool folded = false;
  // "clean", "resolved (...)", "split", "folded (...)"; empty: not checked.
  std::string fold_outcome;
  // The joining of its rigid parts (pipeline/part_merge.h), e.g. "3 rigid
  // parts -> 1 (1 round, 40 pairs removed)"; empty: the model was one
  // rigid piece or not tried.
  std::string part_merge;
};

class ComponentMapper {
 public:
  // `options`: with the mapper-wide settings applied (ForStages), copied so a
  // temporary may be passed; `database` and `cameras` (the view graph's) must
  // outlive the mapper. `log_prefix`
  // starts every log line and note (e.g. "[component 1] ").
  ComponentMapper(const GlobalMapperOptions& options,
                  const DatabaseContents& database,
                  const std::map<camera_t, Camera>& cameras,
                  std::string log_prefix = "");
  virtual ~ComponentMapper() = default;

  // Maps the component (`images`, `pairs`; `evidence` about its pairs, see
  // BuildFoldEvidence) into its models. Empty when none results, with the
  // reason in failure(). Notes for summary.json go to notes().
  std::vector<ComponentModel> Map(const FoldEvidence& evidence,
                                  const std::vector<image_t>& images,
                                  const std::vector<ImagePairGeometry>& pairs);

  const std::vector<std::string>& notes() const { return notes_; }
  const std::string& failure() const { return failure_; }

 protected:
  // The mapper of one attempt (the test seam: tests return a stand-in whose
  // stages copy a given model).
  virtual std::unique_ptr<GlobalMapper> NewMapper(
      const std::vector<image_t>& images,
      const std::vector<ImagePairGeometry>& pairs, const std::string& prefix,
      const FoldEvidence* evidence) const;
  const GlobalMapperOptions& options() const { return options_; }

 private:
  // A solved attempt on (images, pairs): positioned and fold-checked, and
  // refined unless a fold is to be resolved; null when it gave no model
  // (failure_ says why).
  std::unique_ptr<GlobalMapper> Attempt(
      const std::vector<image_t>& images,
      const std::vector<ImagePairGeometry>& pairs, const std::string& prefix);
  // The same with a mapper made by NewMapper (its rotations possibly
  // averaged already: Solve() goes on from them).
  std::unique_ptr<GlobalMapper> Attempt(std::unique_ptr<GlobalMapper> mapper);
  // Refines the attempt if not yet done and adds it to models_ with
  // `outcome` (empty: the fold check's verdict), flagged folded if
  // `folded`. False when the refinement gave up.
  bool Finish(std::unique_ptr<GlobalMapper> mapper, const std::string& outcome,
              bool folded = false);
  // Whether a re-mapped attempt is taken: not folded after positioning nor
  // after refinement, and keeping most of the first model's images.
  bool Accepted(GlobalMapper* mapper);
  // Whether a model of `num_images` keeps at least 3/4 of `reference`'s.
  static bool KeepsMost(size_t num_images, size_t num_reference_images);

  // A model the fold check finds clean, in the pose priors' frame: mapped
  // again across the candidate cuts of pipeline/prior_fold.h (`pairs`: the
  // component's); the re-mapped model the priors agree with clearly better
  // and the images accept is written (true) instead of `model`.
  bool SettleFoldWithPriors(std::unique_ptr<GlobalMapper>* model,
                            const std::vector<ImagePairGeometry>& pairs);

  // The resolution's steps, in order; each returns true when it wrote the
  // component's models (to models_).
  // 1. Re-orientation across the weakest cut: the pairs across it that the
  // folded model agrees with are removed, and the component mapped again.
  bool ReorientAcrossCut();
  // ... and cameras turned alone among cameras the right way round, once;
  // when taken, sets the pairs at them removed and the pairs removed
  // earlier that are given back (each on its own: more may be given back
  // than removed).
  // `mapped_pairs` (optional): set to the pairs the taken model was mapped
  // from.
  bool ReorientImagesTurnedAlone(
      std::unique_ptr<GlobalMapper>* attempt,
      const std::vector<ImagePairGeometry>& pairs, size_t* num_pairs_removed,
      size_t* num_pairs_restored,
      std::vector<ImagePairGeometry>* mapped_pairs = nullptr);
  // Writes the model of `mapper` flagged folded, `num_images` cameras in it
  // possibly turned alone: outcome "folded (N images may be turned alone" +
  // `outcome_reason` + ")", the note with `note_reason`.
  void WriteTurnedAlone(std::unique_ptr<GlobalMapper> mapper, size_t num_images,
                        const std::string& note_reason,
                        const std::string& outcome_reason);
  // After a settling by the priors (the model `attempt`, mapped from
  // `pairs`): a camera turned alone that the fold check does not see looks
  // like a GPS outlier (its prior off the model). Each camera whose prior is
  // beyond the prior gate is turned back across its own pairs
  // (TurnBackAlone); those whose prior the turned-back pose meets (within
  // the gate, at most half as far off) are mapped again with
  // those pairs instead of the ones at them the model agrees with. The
  // re-mapped model is taken when it settles them (LoneTurnSettled) and the
  // images accept it (`num_turned` set); otherwise the model is written
  // flagged folded and false is returned (the priors say the cameras are
  // turned; the mapping does not settle it).
  bool TurnBackLoneCameras(std::unique_ptr<GlobalMapper>* attempt,
                           const std::vector<ImagePairGeometry>& pairs,
                           size_t* num_turned);
  // 2. Removal of the suspect pairs, and the component mapped again.
  bool RemoveSuspectPairs();
  // 3. Split at the weakest cut: separate models rather than a folded one.
  bool SplitAtCut();
  // 4. Otherwise: the best model, written flagged folded.
  void WriteFolded();

  // A model mapped from `pairs` (the fold check found it clean) that is not
  // one rigid piece: its parts joined through the pairs across them that
  // their 3D points confirm, the pairs contradicting the join removed and
  // the component mapped again (pipeline/part_merge.h). The re-mapped model
  // replaces the model only when it is not folded, is less split and writes
  // no fewer images (within PartMergeOptions::min_image_fraction); up to
  // max_rounds rounds while it stays split.
  // Returns whether it checked the rigidity of the model it leaves (then in
  // `rigidity`: the check is not run twice).
  bool MergeRigidParts(ComponentModel* model,
                       const std::vector<ImagePairGeometry>& pairs,
                       ModelRigidity* rigidity);
  // The parts a model of `rigidity` is written as: none when it is one
  // rigid piece (written whole), else its blocks of min_model_size images or
  // more (pointers into rigidity.blocks). The one rule for
  // NumWrittenImages and SplitIntoRigidParts.
  std::vector<const std::vector<image_t>*> WrittenParts(
      const ModelRigidity& rigidity) const;
  // The images a model of `rigidity` is written with: all when it is one
  // rigid piece, else those of its WrittenParts.
  size_t NumWrittenImages(const Reconstruction& reconstruction,
                          const ModelRigidity& rigidity) const;
  // Writes a model that is not one rigid piece as its rigid parts.
  // `rigidity`: the model's, when already checked (null: checked here).
  std::vector<ComponentModel> SplitIntoRigidParts(
      ComponentModel model, const ModelRigidity* rigidity = nullptr);

  const GlobalMapperOptions options_;
  const DatabaseContents& database_;
  const std::map<camera_t, Camera>& cameras_;
  const std::string prefix_;

  // The state of one Map().
  const FoldEvidence* evidence_ = nullptr;
  // The component's pairs, before any resolution step removed some.
  const std::vector<ImagePairGeometry>* component_pairs_ = nullptr;
  size_t num_first_images_ = 0;  // of the first (folded) model
  std::vector<ImagePairGeometry> current_pairs_;
  std::unique_ptr<GlobalMapper> best_;  // the best-supported model so far
  size_t num_removed_ = 0;              // pairs removed so far
  std::vector<ComponentModel> models_;
  std::vector<std::string> notes_;
  std::string failure_;
};

}  // namespace colmap_irav4
