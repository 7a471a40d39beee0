#include "colmap_irav4/refinement/two_view_check.h"

#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/refinement/triangulation.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

constexpr image_t kImage1 = 3;
constexpr image_t kImage2 = 4;

// Adds a keypoint at `xy` to the image; returns its index.
point2D_t AddKeypoint(const Eigen::Vector2d& xy, Image* image) {
  Point2D point2D;
  point2D.xy = xy;
  image->points2D.push_back(point2D);
  return static_cast<point2D_t>(image->points2D.size() - 1);
}

Eigen::Vector2d Project(const Reconstruction& model, image_t image_id,
                        const Eigen::Vector3d& xyz) {
  const Image& image = model.images.at(image_id);
  return CameraCameraToImage(model.cameras.at(image.camera_id),
                             (image.cam_from_world * xyz).hnormalized());
}

// Relative rotation error (deg) of the pair against the truth.
double PairRotationError(const Reconstruction& model,
                         const Reconstruction& truth) {
  const auto relative = [](const Reconstruction& m) {
    return (m.images.at(kImage2).cam_from_world.rotation *
            m.images.at(kImage1).cam_from_world.rotation.inverse())
        .toRotationMatrix();
  };
  return AngularDistanceDeg(relative(model), relative(truth));
}

// A model of 8 images with 150 points seen by all, plus two-view points of
// the pair (kImage1, kImage2): `num_good` of new true points and `num_wrong`
// whose keypoint in kImage2 is shifted 8 px across the epipolar lines (the
// cameras are on a horizontal arc), as a match between repeated structures
// that no third image checks.
struct Scene {
  Reconstruction truth;
  Reconstruction model;
  std::vector<std::pair<point2D_t, point2D_t>> wrong;  // keypoints
};

Scene MakeScene(int num_good, int num_wrong) {
  SyntheticSceneOptions options;
  options.num_images = 8;
  options.num_points = 150;
  options.noise_px = 0.3;
  options.seed = 5;
  Scene scene;
  scene.truth = GenerateSyntheticScene(options).truth;
  scene.model = scene.truth;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-2.0, 2.0);
  std::normal_distribution<double> noise(0.0, 0.3);
  for (int k = 0; k < num_good + num_wrong; ++k) {
    const Eigen::Vector3d xyz(uniform(rng), uniform(rng), uniform(rng));
    const bool wrong = k >= num_good;
    const Eigen::Vector2d xy1 = Project(scene.model, kImage1, xyz) +
                                Eigen::Vector2d(noise(rng), noise(rng));
    const Eigen::Vector2d xy2 = Project(scene.model, kImage2, xyz) +
                                Eigen::Vector2d(noise(rng), noise(rng)) +
                                Eigen::Vector2d(0, wrong ? 8.0 : 0.0);
    const point2D_t idx1 = AddKeypoint(xy1, &scene.model.images.at(kImage1));
    const point2D_t idx2 = AddKeypoint(xy2, &scene.model.images.at(kImage2));
    AddPoint3D(xyz, {{kImage1, idx1}, {kImage2, idx2}}, &scene.model);
    if (wrong) scene.wrong.emplace_back(idx1, idx2);
  }
  return scene;
}

BundleAdjustmentOptions Adjustment() {
  BundleAdjustmentOptions options;
  options.loss_function = BundleAdjustmentLoss::kTrivial;  // the mapper's
  options.weight_by_keypoint_scale = false;
  options.num_rounds = 1;
  options.max_reproj_error = 4.0;
  return options;
}

TEST(TwoViewCheck, RemovesWrongTwoViewMatchesThatBentThePoses) {
  Scene scene = MakeScene(/*num_good=*/60, /*num_wrong=*/120);
  ASSERT_TRUE(RunBundleAdjustment(Adjustment(), &scene.model));
  // The wrong matches bent the pair and passed the 4 px filter.
  size_t num_wrong_kept = 0;
  for (const auto& [idx1, idx2] : scene.wrong) {
    num_wrong_kept +=
        scene.model.images.at(kImage1).points2D[idx1].point3D_id !=
        kInvalidPoint3DId;
  }
  EXPECT_GT(num_wrong_kept, scene.wrong.size() / 2);
  const double bent = PairRotationError(scene.model, scene.truth);
  EXPECT_GT(bent, 0.05);

  TwoViewCheckSummary summary;
  ASSERT_TRUE(CheckTwoViewPoints(
      TwoViewCheckOptions(), Adjustment(), TriangulationOptions(),
      PoseConstraintOptions(), &scene.model, nullptr, &summary));
  EXPECT_EQ(summary.num_points_checked, 60 + num_wrong_kept);
  // The true two-view points come back, the wrong ones do not.
  EXPECT_GE(summary.num_points_restored, 57u);
  EXPECT_LE(summary.num_points_restored, 60u);
  for (const auto& [idx1, idx2] : scene.wrong) {
    EXPECT_EQ(scene.model.images.at(kImage1).points2D[idx1].point3D_id,
              kInvalidPoint3DId);
    EXPECT_EQ(scene.model.images.at(kImage2).points2D[idx2].point3D_id,
              kInvalidPoint3DId);
  }
  ASSERT_TRUE(RunBundleAdjustment(Adjustment(), &scene.model));
  EXPECT_LT(PairRotationError(scene.model, scene.truth), bent / 4);
}

TEST(TwoViewCheck, WeakImagesKeepTheirTwoViewPoints) {
  Scene scene = MakeScene(/*num_good=*/60, /*num_wrong=*/0);
  TwoViewCheckOptions options;
  // Every image has 150 multi-view observations: none is held enough.
  options.min_multi_view_observations = 151;
  const size_t num_points = scene.model.points3D.size();
  TwoViewCheckSummary summary;
  ASSERT_TRUE(CheckTwoViewPoints(options, Adjustment(), TriangulationOptions(),
                                 PoseConstraintOptions(), &scene.model, nullptr,
                                 &summary));
  EXPECT_EQ(summary.num_points_checked, 0u);
  EXPECT_EQ(scene.model.points3D.size(), num_points);
}

TEST(TwoViewCheck, OptionsCheckNamesTheOption) {
  TwoViewCheckOptions options;
  options.max_reproj_error = 0;
  try {
    options.Check();
    FAIL() << "no error";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("TwoViewCheck.max_reproj_error"),
              std::string::npos);
  }
  options = TwoViewCheckOptions();
  options.min_multi_view_observations = -1;
  EXPECT_THROW(options.Check(), InputError);
}

}  // namespace
}  // namespace colmap_irav4
