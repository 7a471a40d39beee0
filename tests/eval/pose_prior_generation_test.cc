// Scenes with GPS-like pose priors: their statistics, and the same priors
// read back from every database schema and the text files.

#include <cmath>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/scene_generator.h"
#include "colmap_irav4/io/pose_priors.h"
#include "tests/test_utils/database_test_utils.h"

namespace colmap_irav4 {
namespace {

SceneGeneratorOptions SmallScene() {
  SceneGeneratorOptions options;
  options.num_images = 40;
  return options;
}

TEST(PosePriorGeneration, NoiseOutliersAndFrame) {
  const GeneratedScene scene = GenerateScene(SmallScene());
  PosePriorGeneratorOptions options;
  options.outlier_fraction = 0.1;
  const GeneratedPosePriors priors = GeneratePosePriors(scene, options);
  ASSERT_EQ(priors.enu.size(), 40u);
  const Reconstruction truth = TruthInPriorFrame(scene, priors);
  int num_far = 0;
  double sum_sq_h = 0, sum_sq_v = 0;
  for (const auto& [image_id, enu] : priors.enu) {
    const Eigen::Vector3d error =
        enu - truth.images.at(image_id).ProjectionCenter();
    if (priors.outliers.count(image_id)) {
      EXPECT_GE(error.norm(), 30.0 - 20.0);  // 30-100 m plus the noise
      ++num_far;
      continue;
    }
    sum_sq_h += error.head<2>().squaredNorm() / 2;
    sum_sq_v += error.z() * error.z();
    // Gravity: 1 deg noise per axis, from the true down.
    const Eigen::Vector3d down =
        truth.images.at(image_id).cam_from_world.rotation *
        Eigen::Vector3d(0, 0, -1);
    EXPECT_LT(
        std::acos(std::min(1.0, down.dot(priors.wgs84.at(image_id).gravity))),
        5.0 * M_PI / 180);
  }
  EXPECT_EQ(num_far, static_cast<int>(priors.outliers.size()));
  EXPECT_GE(num_far, 1);
  const int num_inliers = 40 - num_far;
  EXPECT_NEAR(std::sqrt(sum_sq_h / num_inliers), 3.0, 1.2);
  EXPECT_NEAR(std::sqrt(sum_sq_v / num_inliers), 5.0, 2.0);
  // The truth in the priors' frame: z up (cameras at eye height above the
  // ground of the walls' bottoms), metric (same distances as the scene's).
  const auto first = scene.truth.images.begin();
  const auto last = std::prev(scene.truth.images.end());
  EXPECT_NEAR(
      (truth.images.at(first->first).ProjectionCenter() -
       truth.images.at(last->first).ProjectionCenter())
          .norm(),
      (first->second.ProjectionCenter() - last->second.ProjectionCenter())
          .norm(),
      1e-6);
  // The scene is the same with or without priors.
  const GeneratedScene again = GenerateScene(SmallScene());
  EXPECT_EQ(again.truth.points3D.size(), scene.truth.points3D.size());
}

TEST(PosePriorGeneration, EverySchemaAndTheTextFilesReadTheSame) {
  const GeneratedScene scene = GenerateScene(SmallScene());
  const GeneratedPosePriors priors =
      GeneratePosePriors(scene, PosePriorGeneratorOptions());
  std::map<std::string, image_t> ids;
  for (const auto& [image_id, image] : scene.truth.images) {
    ids[image.name] = image_id;
  }
  test::TempDir temp;
  std::map<std::string, LocalPosePriors> read;
  for (const std::string schema : {"colmap38", "colmap311", "colmap4"}) {
    const std::string path = temp.File(schema + ".db");
    WriteSceneDatabase(scene, path);
    WritePosePriorsToDatabase(path, PosePriorSchemaFromName(schema),
                              priors.wgs84);
    read[schema] =
        ConvertPosePriors(ReadDatabasePosePriors(Database(path)), ids);
  }
  WritePosePriorText(scene, priors, true, temp.File("wgs84.txt"));
  WritePosePriorText(scene, priors, false, temp.File("enu.txt"));
  read["wgs84.txt"] =
      ConvertPosePriors(ReadPosePriorText(temp.File("wgs84.txt"), true), ids);
  read["enu.txt"] =
      ConvertPosePriors(ReadPosePriorText(temp.File("enu.txt"), false), ids);
  for (const auto& [source, local] : read) {
    SCOPED_TRACE(source);
    ASSERT_EQ(local.num_positions, 40);
    EXPECT_EQ(local.is_enu, source != "enu.txt");
    for (const auto& [image_id, enu] : priors.enu) {
      // Text: 12 significant digits of a latitude are 0.1 mm.
      EXPECT_LT((local.priors.at(image_id).position - enu).norm(), 1e-3);
    }
  }
  EXPECT_EQ(read.at("colmap4").num_gravity, 40);
  EXPECT_EQ(read.at("colmap311").num_gravity, 0);
  EXPECT_TRUE(
      read.at("colmap311").priors.begin()->second.HasPositionCovariance());
}

}  // namespace
}  // namespace colmap_irav4
