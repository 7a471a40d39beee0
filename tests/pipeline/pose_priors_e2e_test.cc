// The mapper with pose priors end to end: a generated scene's database with
// GPS-like priors (COLMAP 4's pose_priors table) gives a model in the
// priors' frame, compared with the truth there without any alignment.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/model_alignment.h"
#include "colmap_irav4/eval/scene_generator.h"
#include "colmap_irav4/io/model_io.h"
#include "colmap_irav4/pipeline/global_pipeline.h"
#include "tests/test_utils/database_test_utils.h"

namespace colmap_irav4 {
namespace {

// The mapper on one thread, with or without the database's priors.
GlobalMapperSummary MapDatabase(const std::string& database, bool use_priors,
                                const std::string& output) {
  GlobalMapperOptions options;
  options.num_threads = 1;
  options.use_pose_priors = use_priors;
  std::filesystem::create_directories(output);
  return RunGlobalMapperOnDatabase(options, database, "", output, "BIN");
}

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
    const std::string output = temp.File(use_priors ? "with" : "without");
    const GlobalMapperSummary summary =
        MapDatabase(database, use_priors, output);
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
    // The generator's GPS outliers (5%, 30-100 m off) are left out of the
    // last bundle adjustment, and only they.
    ASSERT_FALSE(priors.outliers.empty());
    std::vector<std::string> outliers;
    for (const image_t image_id : priors.outliers) {
      outliers.push_back(scene.truth.images.at(image_id).name);
    }
    std::vector<std::string> rejected =
        summary.components[0].rejected_position_priors;
    std::sort(outliers.begin(), outliers.end());
    std::sort(rejected.begin(), rejected.end());
    EXPECT_EQ(rejected, outliers);
    EXPECT_TRUE(summary.components[0].rejected_gravity_priors.empty());
    EXPECT_NE(
        json.str().find("\"rejected_position_priors\": [\"" + outliers.front()),
        std::string::npos);
  }
}

// Without GPS outliers no prior is left out: the gate (6 std) is far beyond
// valid noise.
TEST(PosePriorsEndToEnd, NoValidPriorLeftOut) {
  SceneGeneratorOptions scene_options;
  scene_options.num_images = 60;
  scene_options.seed = 2;
  PosePriorGeneratorOptions clean;
  clean.outlier_fraction = 0;
  const GeneratedScene scene = GenerateScene(scene_options);
  test::TempDir temp;
  const std::string database = temp.File("database.db");
  WriteSceneDatabase(scene, database);
  WritePosePriorsToDatabase(database, PosePriorSchema::kColmap4,
                            GeneratePosePriors(scene, clean).wgs84);
  const GlobalMapperSummary summary =
      MapDatabase(database, true, temp.File("model"));
  ASSERT_EQ(summary.components.size(), 1u);
  EXPECT_TRUE(summary.components[0].in_prior_frame);
  EXPECT_TRUE(summary.components[0].rejected_position_priors.empty());
  EXPECT_TRUE(summary.components[0].rejected_gravity_priors.empty());
}

// Two parts of the view graph with no verified pair between them: each is
// mapped as its own model, and each is placed in the priors' frame by its
// own priors, so the two models share the map frame as written.
TEST(PosePriorsEndToEnd, DisconnectedPartsEachPlacedInThePriorFrame) {
  // A courtyard loop of 40 images 1 m apart (a 40 m loop): each half, an
  // arc of ~20 m, is larger than the GPS noise, as on a real capture.
  SceneGeneratorOptions scene_options;
  scene_options.num_images = 40;
  scene_options.image_spacing = 1.0;
  const GeneratedScene scene = GenerateScene(scene_options);
  const PosePriorGeneratorOptions prior_options;
  const GeneratedPosePriors priors = GeneratePosePriors(scene, prior_options);
  test::TempDir temp;
  const std::string database = temp.File("database.db");
  WriteSceneDatabase(scene, database);
  WritePosePriorsToDatabase(database, PosePriorSchema::kColmap4, priors.wgs84);
  {
    // Cut every verified pair between images 1..20 and 21..40 (the two
    // halves of the loop).
    test::SqliteWriter writer(database);
    writer.Exec(
        "DELETE FROM two_view_geometries WHERE "
        "((pair_id / 2147483647) <= 20) != ((pair_id % 2147483647) <= 20);");
  }
  const std::map<std::string, Rigid3d> truth =
      PosesByName(TruthInPriorFrame(scene, priors));
  // A similarity fitted to n independent positions of standard deviation
  // sigma per axis leaves errors of about sigma * sqrt(7 / n) per camera
  // (7 degrees of freedom), here sqrt(3^2 + 3^2 + 5^2) * sqrt(7 / 20) = 3.9 m
  // in 3D; the images only add shape. Bound: the median camera within that,
  // every camera within twice the 3D standard deviation of one fix.
  const double sigma_3d = std::sqrt(
      2.0 * prior_options.horizontal_std * prior_options.horizontal_std +
      prior_options.vertical_std * prior_options.vertical_std);

  for (const bool use_priors : {true, false}) {
    SCOPED_TRACE(use_priors ? "with priors" : "without");
    const std::string output = temp.File(use_priors ? "with" : "without");
    const GlobalMapperSummary summary =
        MapDatabase(database, use_priors, output);
    ASSERT_EQ(summary.components.size(), 2u);
    EXPECT_FALSE(std::filesystem::exists(output + "/2"));
    for (int k = 0; k < 2; ++k) {
      SCOPED_TRACE("model " + std::to_string(k));
      EXPECT_EQ(summary.components[k].in_prior_frame, use_priors);
      const std::string path = output + "/" + std::to_string(k);
      const Reconstruction model = ReadReconstruction(path);
      // Each model holds images of one half only.
      const bool first_half = model.images.begin()->first <= 20;
      for (const auto& [image_id, image] : model.images) {
        EXPECT_EQ(image_id <= 20, first_half) << image_id;
      }
      EXPECT_GE(model.images.size(), 15u);
      PoseComparison unaligned;
      ASSERT_TRUE(ComparePoses(PosesByName(model), truth,
                               SimilarityRansacOptions(), &unaligned, false));
      std::printf(
          "%s model %d: %d images, centre median %.2f max %.2f m, "
          "rotation median %.2f max %.2f deg\n",
          use_priors ? "with priors" : "without", k, unaligned.num_common,
          unaligned.center_error_median, unaligned.center_error_max,
          unaligned.rotation_error_median_deg,
          unaligned.rotation_error_max_deg);
      EXPECT_EQ(std::filesystem::exists(path + "/prior_frame.txt"), use_priors);
      // The heading is what the positions know least: n fixes of
      // horizontal deviation h spread over a horizontal radius r (RMS about
      // their centre) give it to about h / (r sqrt(n)) radians (gravity
      // fixes the tilt to ~1 deg). Bound: three times that.
      Eigen::Vector2d mean = Eigen::Vector2d::Zero();
      std::vector<Eigen::Vector2d> centres;
      for (const std::string& name : unaligned.names) {
        centres.push_back(truth.at(name).Inverse().translation.head<2>());
        mean += centres.back() / unaligned.names.size();
      }
      double spread = 0;
      for (const Eigen::Vector2d& c : centres) {
        spread += (c - mean).squaredNorm() / centres.size();
      }
      const double n = static_cast<double>(centres.size());
      const double heading_bound_deg = 3.0 * prior_options.horizontal_std /
                                       (std::sqrt(spread) * std::sqrt(n)) *
                                       180.0 / M_PI;
      const double center_bound = sigma_3d * std::sqrt(7.0 / n);
      std::printf("  bounds: centre median %.2f m, heading %.2f deg\n",
                  center_bound, heading_bound_deg);
      if (use_priors) {
        EXPECT_LT(unaligned.center_error_median, center_bound);
        EXPECT_LT(unaligned.center_error_max, 2.0 * sigma_3d);
        EXPECT_LT(unaligned.rotation_error_median_deg, heading_bound_deg);
      } else {
        // Normalised, each in its own arbitrary frame.
        EXPECT_GT(unaligned.center_error_median, center_bound);
        EXPECT_GT(unaligned.rotation_error_median_deg, heading_bound_deg);
      }
    }
  }
}

}  // namespace
}  // namespace colmap_irav4
