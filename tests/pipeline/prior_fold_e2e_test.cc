// A fold the images alone leave silent, settled by the pose priors
// (pipeline/prior_fold.h): a tower seen from a loop of 40 cameras, whose
// opposite faces look alike, with half of its pairs mirror-twin false pairs
// keeping 70% of a true pair's matches. Without priors the model folds
// (about half the cameras turned 180 deg onto their twins' side) and the
// fold check finds nothing conclusive; with GPS-like priors (3 m
// horizontal, 5 m vertical, 5% outliers) every camera comes out right, in
// the priors' frame.

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/model_alignment.h"
#include "colmap_irav4/eval/scene_generator.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/io/pose_priors.h"
#include "colmap_irav4/pipeline/global_pipeline.h"
#include "tests/test_utils/database_test_utils.h"

namespace colmap_irav4 {
namespace {

// The symmetric suite's tower (scripts/symmetric_benchmark.sh with the
// GEN_ARGS of docs/notes/2026-12-04-priors-table.md): half of its pairs
// mirror-twin pairs keeping 70% of a true pair's matches.
SceneGeneratorOptions SuiteTower(int num_images, uint64_t seed) {
  SceneGeneratorOptions options;
  options.layout = SceneLayout::kTower;
  options.num_images = num_images;
  options.point_density = 15;
  options.noise_px = 0.5;
  options.mirror_pair_rate = 0.5;
  options.false_pair_inlier_fraction = 0.7;
  options.seed = seed;
  return options;
}

struct TowerRun {
  GlobalMapperSummary summary;
  Reconstruction model;      // the first (only) model
  int num_turned = 0;        // rotation error > 30 deg, similarity-aligned
  PoseComparison unaligned;  // in the priors' frame as written
};

class PriorFoldTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const SceneGeneratorOptions options = SuiteTower(40, 1);
    scene_ = new GeneratedScene(GenerateScene(options));
    PosePriorGeneratorOptions prior_options;
    prior_options.seed = options.seed;
    priors_ =
        new GeneratedPosePriors(GeneratePosePriors(*scene_, prior_options));
    temp_ = new test::TempDir();
    database_ = temp_->File("database.db");
    WriteSceneDatabase(*scene_, database_);
    // COLMAP 3.8's columns: positions without covariance (5 m default).
    WritePosePriorsToDatabase(database_, PosePriorSchema::kColmap38,
                              priors_->wgs84);
  }
  static void TearDownTestSuite() {
    delete temp_;
    delete priors_;
    delete scene_;
  }

  static TowerRun Map(bool use_priors, bool settle_with_priors,
                      const std::string& name) {
    GlobalMapperOptions options;
    options.num_threads = 1;
    options.use_pose_priors = use_priors;
    options.fold.settle_with_priors = settle_with_priors;
    const std::string output = temp_->File(name);
    std::filesystem::create_directories(output);
    TowerRun run;
    run.summary =
        RunGlobalMapperOnDatabase(options, database_, "", output, "BIN");
    EXPECT_EQ(run.summary.components.size(), 1u);
    if (run.summary.components.empty()) return run;
    run.model = ReadReconstruction(output + "/0");
    PoseComparison aligned;
    EXPECT_TRUE(ComparePoses(PosesByName(run.model), PosesByName(scene_->truth),
                             SimilarityRansacOptions(), &aligned));
    for (const double error : aligned.rotation_errors_deg) {
      run.num_turned += error > 30.0;
    }
    EXPECT_TRUE(ComparePoses(PosesByName(run.model),
                             PosesByName(TruthInPriorFrame(*scene_, *priors_)),
                             SimilarityRansacOptions(), &run.unaligned,
                             /*align=*/false));
    return run;
  }

  static GeneratedScene* scene_;
  static GeneratedPosePriors* priors_;
  static test::TempDir* temp_;
  static std::string database_;
};

GeneratedScene* PriorFoldTest::scene_ = nullptr;
GeneratedPosePriors* PriorFoldTest::priors_ = nullptr;
test::TempDir* PriorFoldTest::temp_ = nullptr;
std::string PriorFoldTest::database_;

TEST_F(PriorFoldTest, FoldSettledByThePriors) {
  const TowerRun run = Map(true, true, "settled");
  ASSERT_EQ(run.summary.components.size(), 1u);
  const ComponentReport& component = run.summary.components[0];
  EXPECT_TRUE(component.in_prior_frame);
  EXPECT_FALSE(component.folded);
  EXPECT_EQ(component.fold_outcome.rfind("resolved by pose priors", 0), 0u)
      << component.fold_outcome;
  // Every camera the right way round, nearly all registered.
  EXPECT_EQ(run.num_turned, 0);
  EXPECT_GE(run.model.images.size(), 36u);
  // In the priors' frame without alignment: the tower's loop (~30 m
  // across) placed by 40 fixes of 3-5 m, every camera within a few metres
  // (a turned one sits tens of metres off, at its twin's place).
  EXPECT_LT(run.unaligned.center_error_median, 3.0);
  EXPECT_LT(run.unaligned.center_error_max, 8.0);
  EXPECT_LT(run.unaligned.rotation_error_max_deg, 10.0);
}

TEST_F(PriorFoldTest, SilentFoldWithoutSettling) {
  // The same priors, the settling off: the model is folded and the fold
  // check finds nothing (what the mapper did before).
  const TowerRun run = Map(true, false, "not_settled");
  ASSERT_EQ(run.summary.components.size(), 1u);
  EXPECT_EQ(run.summary.components[0].fold_outcome, "clean");
  EXPECT_TRUE(run.summary.components[0].in_prior_frame);
  EXPECT_GE(run.num_turned, 10);
  EXPECT_GT(run.unaligned.center_error_max, 20.0);
}

TEST_F(PriorFoldTest, WithoutPriorsUnchanged) {
  // --Mapper.use_pose_priors 0: the settling has nothing to judge by; the
  // same silent fold as with the settling off.
  const TowerRun off = Map(false, true, "no_priors");
  const TowerRun reference = Map(false, false, "no_priors_no_settling");
  ASSERT_EQ(off.summary.components.size(), 1u);
  ASSERT_EQ(reference.summary.components.size(), 1u);
  EXPECT_FALSE(off.summary.components[0].in_prior_frame);
  EXPECT_EQ(off.summary.components[0].fold_outcome, "clean");
  EXPECT_GE(off.num_turned, 10);
  EXPECT_EQ(off.num_turned, reference.num_turned);
  EXPECT_EQ(off.model.images.size(), reference.model.images.size());
}

// One camera left turned alone after a settling by the pose priors
// (docs/notes/2026-12-04-lone-turned-camera.md): the tower of 60 images,
// seed 2, of the symmetric suite, with GPS-like priors and gravity in COLMAP
// 4's table. The priors settle the half-turn, but image35 stayed turned
// 180 deg, 70.8 m from its place, its prior left out like a GPS outlier's,
// and the model was written clean (exit 0). Turned back across its own
// pairs it meets its prior: the mapper maps it again and every camera comes
// out right but image46 (below).

TEST(LoneTurnedCamera, TowerSeedTwoTurnedBackToItsPrior) {
  const SceneGeneratorOptions options = SuiteTower(60, 2);
  const GeneratedScene scene = GenerateScene(options);
  PosePriorGeneratorOptions prior_options;
  prior_options.seed = options.seed;
  const GeneratedPosePriors priors = GeneratePosePriors(scene, prior_options);
  test::TempDir temp;
  const std::string database = temp.File("database.db");
  WriteSceneDatabase(scene, database);
  WritePosePriorsToDatabase(database, PosePriorSchema::kColmap4, priors.wgs84);

  GlobalMapperOptions mapper_options;
  mapper_options.num_threads = 1;
  const std::string output = temp.File("out");
  std::filesystem::create_directories(output);
  const GlobalMapperSummary summary =
      RunGlobalMapperOnDatabase(mapper_options, database, "", output, "BIN");
  ASSERT_EQ(summary.components.size(), 1u);
  const ComponentReport& component = summary.components[0];
  EXPECT_TRUE(component.in_prior_frame);
  EXPECT_FALSE(component.folded);
  EXPECT_NE(component.fold_outcome.find("1 cameras turned alone turned back "
                                        "to their priors"),
            std::string::npos)
      << component.fold_outcome;
  const Reconstruction model = ReadReconstruction(output + "/0");
  EXPECT_EQ(model.images.size(), 55u);
  // In the priors' frame as written: image35 right (main left it at
  // 179.99 deg, 70.8 m off) and so is every other camera but image46.
  // image46 carries a generated GPS outlier and is turned alone as well in
  // this database (the suite's has the fold check name it weak alone): its
  // prior cannot say which way it faces, turned back it is as far from its
  // fix (28.8 -> 27.9 std). Left open (see the note).
  PoseComparison unaligned;
  ASSERT_TRUE(ComparePoses(PosesByName(model),
                           PosesByName(TruthInPriorFrame(scene, priors)),
                           SimilarityRansacOptions(), &unaligned,
                           /*align=*/false));
  bool has_image35 = false;
  for (size_t i = 0; i < unaligned.names.size(); ++i) {
    if (unaligned.names[i] == "image46.jpg") continue;
    has_image35 |= unaligned.names[i] == "image35.jpg";
    EXPECT_LT(unaligned.rotation_errors_deg[i], 5.0) << unaligned.names[i];
    EXPECT_LT(unaligned.center_errors[i], 3.0) << unaligned.names[i];
  }
  EXPECT_TRUE(has_image35);
}

}  // namespace
}  // namespace colmap_irav4
