#include "colmap_irav4/positioning/translation_averaging.h"

#include <random>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/model_alignment.h"
#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/util/error.h"
#include "tests/test_utils/scene_test_utils.h"

namespace colmap_irav4 {
namespace {

using test::MaxRelativeCenterError;

// All pairs: t_ij of cam_j_from_cam_i, perturbed by noise_deg, a fraction
// replaced by random directions.
std::vector<ImagePairGeometry> MakePairs(const Reconstruction& truth,
                                         double noise_deg, double outlier_ratio,
                                         uint64_t seed, int* num_outliers) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<ImagePairGeometry> pairs;
  *num_outliers = 0;
  for (const auto& [id1, image1] : truth.images) {
    for (const auto& [id2, image2] : truth.images) {
      if (id2 <= id1) continue;
      ImagePairGeometry pair;
      pair.image_id1 = id1;
      pair.image_id2 = id2;
      pair.t = (image2.cam_from_world.rotation *
                (image1.ProjectionCenter() - image2.ProjectionCenter()))
                   .normalized();
      pair.t = RandomRotationWithAngle(DegToRad(noise_deg), &rng) * pair.t;
      if (unit(rng) < outlier_ratio) {
        pair.t = RandomRotation(&rng) * Eigen::Vector3d::UnitX();
        ++*num_outliers;
      }
      pairs.push_back(pair);
    }
  }
  return pairs;
}

TEST(TranslationAveraging, ExactDirectionsGiveExactCenters) {
  SyntheticSceneOptions scene_options;
  scene_options.num_images = 15;
  scene_options.num_points = 10;
  const SyntheticScene scene = GenerateSyntheticScene(scene_options);
  Reconstruction reconstruction = StripPoints(scene.truth);
  for (auto& [id, image] : reconstruction.images)
    image.cam_from_world.translation.setZero();
  int num_outliers;
  const auto pairs = MakePairs(scene.truth, 0.0, 0.0, 1, &num_outliers);
  TranslationAveragingSummary summary;
  ASSERT_TRUE(RunTranslationAveraging(TranslationAveragingOptions(), pairs,
                                      &reconstruction, &summary));
  EXPECT_EQ(summary.num_images, 15);
  EXPECT_EQ(summary.num_outlier_pairs, 0);
  EXPECT_LT(MaxRelativeCenterError(reconstruction, scene.truth, 10.0), 1e-5);
  // Also from a random start.
  TranslationAveragingOptions options;
  options.linear_initialization = false;
  options.loss_function = LossFunctionType::kHuber;
  ASSERT_TRUE(
      RunTranslationAveraging(options, pairs, &reconstruction, &summary));
  EXPECT_LT(MaxRelativeCenterError(reconstruction, scene.truth, 10.0), 1e-5);
}

TEST(TranslationAveraging, RobustToNoiseAndOutlierPairs) {
  SyntheticSceneOptions scene_options;
  scene_options.num_images = 20;
  scene_options.num_points = 10;
  const SyntheticScene scene = GenerateSyntheticScene(scene_options);
  Reconstruction reconstruction = StripPoints(scene.truth);
  int num_outliers;
  const auto pairs = MakePairs(scene.truth, 1.0, 0.1, 2, &num_outliers);
  ASSERT_GT(num_outliers, 10);

  TranslationAveragingSummary summary;
  ASSERT_TRUE(RunTranslationAveraging(TranslationAveragingOptions(), pairs,
                                      &reconstruction, &summary));
  EXPECT_LT(MaxRelativeCenterError(reconstruction, scene.truth, 10.0), 0.02);
  EXPECT_GE(summary.num_outlier_pairs, num_outliers * 7 / 10);
  EXPECT_LE(summary.num_outlier_pairs, num_outliers + 5);
}

TEST(TranslationAveraging, DropsImagesWithoutPairs) {
  SyntheticSceneOptions scene_options;
  scene_options.num_images = 6;
  scene_options.num_points = 10;
  const SyntheticScene scene = GenerateSyntheticScene(scene_options);
  Reconstruction reconstruction = StripPoints(scene.truth);
  int num_outliers;
  std::vector<ImagePairGeometry> pairs;
  for (const auto& pair : MakePairs(scene.truth, 0.0, 0.0, 3, &num_outliers)) {
    if (pair.image_id1 != 6 && pair.image_id2 != 6) pairs.push_back(pair);
  }
  TranslationAveragingSummary summary;
  ASSERT_TRUE(RunTranslationAveraging(TranslationAveragingOptions(), pairs,
                                      &reconstruction, &summary));
  EXPECT_EQ(summary.num_images_dropped, 1);
  EXPECT_FALSE(reconstruction.images.count(6));
  TranslationAveragingOptions options;
  options.loss_scale = 0;
  EXPECT_THROW(options.Check(), InputError);
}

}  // namespace
}  // namespace colmap_irav4
