// The mapper with pose priors end to end: a generated scene's database with
// GPS-like priors (COLMAP 4's pose_priors table) gives a model in the
// priors' frame, compared with the truth there without any alignment.

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/model_alignment.h"
#include "colmap_irav4/eval/scene_generator.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/pipeline/global_pipeline.h"
#include "tests/test_utils/database_test_utils.h"

namespace colmap_irav4 {
namespace {

TEST(PosePriorsEndToEnd, ModelWrittenInThePriorFrame) {
  SceneGeneratorOptions scene_options;
  scene_options.num_images = 60;
  const GeneratedScene scene = GenerateScene(scene_options);
  const GeneratedPosePriors priors =
      GeneratePosePriors(scene, PosePriorGeneratorOptions());
  test::TempDir temp;
  const std::string database = temp.File("database.db");
  WriteSceneDatabase(scene, database);
  WritePosePriorsToDatabase(database, PosePriorSchema::kColmap4, priors.wgs84);
  const std::map<std::string, Rigid3d> truth =
      PosesByName(TruthInPriorFrame(scene, priors));

  for (const bool use_priors : {true, false}) {
    SCOPED_TRACE(use_priors ? "with priors" : "without");
    GlobalMapperOptions options;
    options.num_threads = 1;
    options.use_pose_priors = use_priors;
    const std::string output = temp.File(use_priors ? "with" : "without");
    std::filesystem::create_directories(output);
    const GlobalMapperSummary summary =
        RunGlobalMapperOnDatabase(options, database, "", output, "BIN");
    ASSERT_EQ(summary.components.size(), 1u);
    EXPECT_EQ(summary.components[0].in_prior_frame, use_priors);
    EXPECT_EQ(summary.pose_priors.num_positions, use_priors ? 60 : 0);
    const Reconstruction model = ReadReconstruction(output + "/0");
    PoseComparison unaligned;
    ASSERT_TRUE(ComparePoses(PosesByName(model), truth,
                             SimilarityRansacOptions(), &unaligned, false));
    if (!use_priors) {
      // Normalised, in rotation averaging's arbitrary orientation.
      EXPECT_GT(unaligned.rotation_error_median_deg, 10.0);
      EXPECT_FALSE(std::filesystem::exists(output + "/0/prior_frame.txt"));
      continue;
    }
    // GPS of 3 m (5 m up) on 60 images around a courtyard of ~8 m: the
    // model sits within a metre or so of the truth, turned by at most a
    // few degrees (heading and scale are what the positions know least).
    EXPECT_LT(unaligned.center_error_median, 1.5);
    EXPECT_LT(unaligned.rotation_error_median_deg, 3.0);
    // Only a similarity from the truth: its shape is as good as without
    // priors (the scale is known to ~3 m / (3 m * sqrt(60)) = 13%: the
    // camera loop is as small as the GPS noise).
    PoseComparison aligned;
    ASSERT_TRUE(ComparePoses(PosesByName(model), truth,
                             SimilarityRansacOptions(), &aligned));
    EXPECT_LT(aligned.center_error_median, 0.02);
    // Where it sits on the map.
    std::ifstream frame(output + "/0/prior_frame.txt");
    std::stringstream text;
    text << frame.rdbuf();
    EXPECT_NE(text.str().find("FRAME ENU"), std::string::npos);
    EXPECT_NE(text.str().find("ORIGIN_WGS84 47.37"), std::string::npos);
    std::ifstream json_file(output + "/summary.json");
    std::stringstream json;
    json << json_file.rdbuf();
    EXPECT_NE(json.str().find("\"in_prior_frame\": true"), std::string::npos);
    EXPECT_NE(json.str().find("\"frame\": \"ENU\""), std::string::npos);
  }
}

}  // namespace
}  // namespace colmap_irav4
