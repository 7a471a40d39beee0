#include "colmap_irav4/refinement/pose_constraint.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "colmap_irav4/util/error.h"

namespace colmap_irav4 {
namespace {

Reconstruction Model() {
  SyntheticSceneOptions options;
  options.num_images = 8;
  options.num_points = 400;
  options.seed = 3;
  return GenerateSyntheticScene(options).truth;
}

const ImagePoseConstraint& Find(const std::vector<ImagePoseConstraint>& list,
                                image_t image_id) {
  for (const ImagePoseConstraint& constraint : list) {
    if (constraint.image_id == image_id) return constraint;
  }
  throw std::runtime_error("image not listed");
}

// Unlinks the observations of `image_id` except every `keep_every`-th.
void Thin(image_t image_id, int keep_every, Reconstruction* model) {
  std::vector<point2D_t> observed;
  const Image& image = model->images.at(image_id);
  for (point2D_t idx = 0; idx < image.points2D.size(); ++idx) {
    if (image.points2D[idx].point3D_id != kInvalidPoint3DId) {
      observed.push_back(idx);
    }
  }
  for (size_t k = 0; k < observed.size(); ++k) {
    if (k % keep_every != 0) DeleteObservation(image_id, observed[k], model);
  }
}

TEST(PoseConstraint, UncertaintyFallsWithTheSquareRootOfTheObservations) {
  Reconstruction model = Model();
  const double full =
      Find(ComputePoseConstraints({}, model), 4).rotation_uncertainty_deg;
  Thin(4, 4, &model);
  const ImagePoseConstraint thinned =
      Find(ComputePoseConstraints({}, model), 4);
  EXPECT_NEAR(thinned.rotation_uncertainty_deg / full, 2.0, 0.3);
  EXPECT_EQ(thinned.num_observations, 100u);
  EXPECT_EQ(thinned.num_multi_view_observations, 100u);
}

TEST(PoseConstraint, FlagsTheImageItsPointsHoldLeast) {
  Reconstruction model = Model();
  std::vector<ImagePoseConstraint> list = ComputePoseConstraints({}, model);
  ASSERT_EQ(list.size(), model.images.size());
  for (const ImagePoseConstraint& constraint : list) {
    EXPECT_FALSE(constraint.poorly_constrained) << constraint.name;
    EXPECT_TRUE(std::isfinite(constraint.rotation_uncertainty_deg));
    EXPECT_GT(constraint.relative_center_uncertainty, 0);
  }
  Thin(5, 10, &model);
  list = ComputePoseConstraints({}, model);
  EXPECT_EQ(list.front().image_id, 5u);  // least constrained first
  for (const ImagePoseConstraint& constraint : list) {
    EXPECT_EQ(constraint.poorly_constrained, constraint.image_id == 5)
        << constraint.name;
  }
}

TEST(PoseConstraint, TwoViewPointsDoNotHoldAPose) {
  Reconstruction model = Model();
  // Image 2's points keep only it and image 3: all its points are two-view.
  std::vector<point3D_t> points;
  for (const Point2D& point2D : model.images.at(2).points2D) {
    if (point2D.point3D_id != kInvalidPoint3DId) {
      points.push_back(point2D.point3D_id);
    }
  }
  for (const point3D_t point3D_id : points) {
    const Track track = model.points3D.at(point3D_id).track;
    for (const TrackElement& element : track) {
      if (element.image_id != 2 && element.image_id != 3) {
        DeleteObservation(element.image_id, element.point2D_idx, &model);
      }
    }
  }
  const ImagePoseConstraint constraint =
      Find(ComputePoseConstraints({}, model), 2);
  EXPECT_EQ(constraint.num_multi_view_observations, 0u);
  EXPECT_GT(constraint.num_observations, 0u);
  EXPECT_TRUE(std::isinf(constraint.rotation_uncertainty_deg));
  EXPECT_TRUE(constraint.poorly_constrained);
}

TEST(PoseConstraint, OptionsCheckNamesTheOption) {
  PoseConstraintOptions options;
  options.max_relative_uncertainty = 1.0;
  try {
    options.Check();
    FAIL() << "no error";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what())
                  .find("PoseConstraint.max_relative_uncertainty"),
              std::string::npos);
  }
  options = PoseConstraintOptions();
  options.min_track_length = 1;
  EXPECT_THROW(options.Check(), InputError);
}

}  // namespace
}  // namespace colmap_irav4
