// One camera left turned alone after a settling by the pose priors
// (docs/notes/2026-12-04-lone-turned-camera.md): the tower of 60 images,
// seed 2, of the symmetric suite, with GPS-like priors and gravity in COLMAP
// 4's table. The priors settle the half-turn, but image35 stayed turned
// 180 deg, 70.8 m from its place, its prior left out like a GPS outlier's,
// and the model was written clean (exit 0). Turned back across its own
// pairs it meets its prior: the mapper maps it again and every camera comes
// out right but image46 (below).

#include <filesystem>
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

TEST(LoneTurnedCamera, TowerSeedTwoTurnedBackToItsPrior) {
  SceneGeneratorOptions options;
  options.layout = SceneLayout::kTower;
  options.num_images = 60;
  options.point_density = 15;
  options.noise_px = 0.5;
  options.mirror_pair_rate = 0.5;
  options.false_pair_inlier_fraction = 0.7;
  options.seed = 2;
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
