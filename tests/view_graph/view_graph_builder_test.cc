#include "colmap_irav4/view_graph/view_graph_builder.h"

#include <algorithm>
#include <map>
#include <sstream>
#include <vector>

#include <gtest/gtest.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/util/error.h"
#include "tests/test_utils/synthetic_two_view.h"

namespace colmap_irav4 {
namespace {

// Images 1..num_images with ground-truth poses; pairs added on demand from
// synthetic views of one scene.
class SyntheticDatabase {
 public:
  explicit SyntheticDatabase(int num_images = 7) : rng_(5) {
    camera_ = test::MakeCamera(CameraModelNameToId("SIMPLE_RADIAL"));
    contents_.cameras[1] = camera_;
    for (image_t id = 1; id <= static_cast<image_t>(num_images); ++id) {
      DatabaseImage image;
      image.image_id = id;
      image.name = "img" + std::to_string(id) + ".jpg";
      image.camera_id = 1;
      contents_.images[id] = image;
      rotations_[id] = RandomRotationWithAngle(DegToRad(8), &rng_);
      centers_[id] = Eigen::Vector3d(0.6 * id, 0.1 * (id % 2), 0);
    }
  }

  // Adds pair (id1, id2) with its own keypoints (appended to both images).
  void AddPair(image_t id1, image_t id2, int num_inliers, int config) {
    const Eigen::Matrix3d R = rotations_[id2] * rotations_[id1].transpose();
    // t of cam2_from_cam1: R2 (C1 - C2).
    const Eigen::Vector3d t = rotations_[id2] * (centers_[id1] - centers_[id2]);
    test::SyntheticPair pair = test::MakeSyntheticPair(
        camera_, camera_, R, t, num_inliers, 0.3, false, &rng_);
    TwoViewGeometry geometry = pair.geometry;
    geometry.image_id1 = id1;
    geometry.image_id2 = id2;
    geometry.config = config;
    FeatureKeypoints& k1 = contents_.keypoints[id1];
    FeatureKeypoints& k2 = contents_.keypoints[id2];
    const point2D_t offset1 = k1.size(), offset2 = k2.size();
    k1.insert(k1.end(), pair.keypoints1.begin(), pair.keypoints1.end());
    k2.insert(k2.end(), pair.keypoints2.begin(), pair.keypoints2.end());
    for (FeatureMatch& match : geometry.inlier_matches) {
      match.point2D_idx1 += offset1;
      match.point2D_idx2 += offset2;
    }
    contents_.two_view_geometries.push_back(geometry);
    truth_[{id1, id2}] = R;
  }

  DatabaseContents contents_;
  std::map<std::pair<image_t, image_t>, Eigen::Matrix3d> truth_;

 private:
  std::mt19937_64 rng_;
  Camera camera_;
  std::map<image_t, Eigen::Matrix3d> rotations_;
  std::map<image_t, Eigen::Vector3d> centers_;
};

TEST(ViewGraphBuilder, FiltersAndKeepsLargestComponent) {
  SyntheticDatabase db;
  const int kCal = TwoViewGeometry::CALIBRATED;
  // Component A: 1-2-3-4 (a triangle and a tail); component B: 5-6.
  db.AddPair(1, 2, 200, kCal);
  db.AddPair(2, 3, 150, kCal);
  db.AddPair(1, 3, 120, TwoViewGeometry::PLANAR_OR_PANORAMIC);
  db.AddPair(3, 4, 100, kCal);
  db.AddPair(5, 6, 300, kCal);
  // Dropped: watermark, too few inliers, degenerate; each would join 7 or 5.
  db.AddPair(4, 5, 200, TwoViewGeometry::WATERMARK);
  db.AddPair(4, 7, 10, kCal);
  db.AddPair(6, 7, 100, TwoViewGeometry::DEGENERATE);
  db.contents_.num_matches[ImagePairToPairId(3, 4)] = 1000;  // ratio 0.1

  ViewGraphBuilderOptions options;
  ViewGraphSummary summary;
  ViewGraph view_graph = BuildViewGraph(db.contents_, options, &summary);
  EXPECT_EQ(summary.num_cameras, 1);
  EXPECT_EQ(summary.num_images, 7);
  EXPECT_EQ(summary.num_pairs_read, 8);
  EXPECT_EQ(summary.num_dropped["config WATERMARK"], 1);
  EXPECT_EQ(summary.num_dropped["config DEGENERATE"], 1);
  EXPECT_EQ(summary.num_dropped["fewer than min_num_inliers inliers"], 1);
  EXPECT_EQ(summary.num_dropped["outside the largest component"], 1);
  EXPECT_EQ(summary.num_components, 2);
  EXPECT_EQ(summary.num_images_in_component, 4);
  EXPECT_EQ(summary.num_pairs_kept, 4);
  ASSERT_EQ(view_graph.pairs.size(), 4u);
  EXPECT_EQ(view_graph.image_names.size(), 4u);
  EXPECT_EQ(view_graph.image_names.at(4), "img4.jpg");
  EXPECT_EQ(view_graph.image_names.count(5), 0u);
  for (const ImagePairGeometry& pair : view_graph.pairs) {
    const Eigen::Matrix3d& R = db.truth_.at({pair.image_id1, pair.image_id2});
    EXPECT_LT(AngularDistanceDeg(pair.R, R), 0.2);
    EXPECT_NEAR(pair.t.norm(), 1.0, 1e-9);
    EXPECT_GT(pair.num_inliers, 15);
  }
  std::ostringstream text;
  summary.Print(text);
  EXPECT_NE(text.str().find("config WATERMARK: 1"), std::string::npos)
      << text.str();

  // The inlier ratio filter applies where raw match counts exist.
  options.min_inlier_ratio = 0.25;
  view_graph = BuildViewGraph(db.contents_, options, &summary);
  EXPECT_EQ(summary.num_dropped["inlier ratio below min_inlier_ratio"], 1);
  EXPECT_EQ(view_graph.pairs.size(), 3u);

  // Keeping every component; dropping PLANAR_OR_PANORAMIC too.
  options = ViewGraphBuilderOptions();
  options.keep_largest_component = false;
  options.drop_configs = "WATERMARK, DEGENERATE,PLANAR_OR_PANORAMIC";
  view_graph = BuildViewGraph(db.contents_, options, &summary);
  EXPECT_EQ(view_graph.pairs.size(), 4u);  // 1-2, 2-3, 3-4, 5-6
  EXPECT_EQ(view_graph.image_names.size(), 6u);
  EXPECT_EQ(summary.num_dropped["config PLANAR_OR_PANORAMIC"], 1);
}

// The relative poses derived with given cameras (a first mapping's refined
// ones) instead of the database's: a focal 5% off and no distortion in the
// database turn the relative rotations by a fraction of a degree or more;
// the right cameras bring them back to the truth, and the view graph holds
// the given cameras.
TEST(ViewGraphBuilder, DerivesRelativePosesWithGivenCameras) {
  SyntheticDatabase db;
  const int kUncal = TwoViewGeometry::UNCALIBRATED;
  for (image_t id = 1; id < 7; ++id) db.AddPair(id, id + 1, 300, kUncal);
  db.AddPair(1, 3, 300, kUncal);
  db.AddPair(4, 6, 300, kUncal);
  const std::map<camera_t, Camera> right = db.contents_.cameras;
  Camera& wrong = db.contents_.cameras.at(1);
  wrong.params[0] *= 1.05;
  wrong.params[3] = 0;
  wrong.has_prior_focal_length = true;

  auto errors = [&](const ViewGraph& view_graph) {
    std::vector<double> result;
    for (const ImagePairGeometry& pair : view_graph.pairs) {
      result.push_back(AngularDistanceDeg(
          pair.R, db.truth_.at({pair.image_id1, pair.image_id2})));
    }
    std::sort(result.begin(), result.end());
    return result;
  };
  ViewGraphBuilderOptions options;
  ViewGraphSummary summary;
  const ViewGraph with_database =
      BuildViewGraph(db.contents_, options, &summary);
  const ViewGraph with_right =
      BuildViewGraph(db.contents_, options, &summary, &right);
  const std::vector<double> database_errors = errors(with_database);
  const std::vector<double> right_errors = errors(with_right);
  ASSERT_EQ(right_errors.size(), 8u);
  ASSERT_EQ(database_errors.size(), 8u);
  EXPECT_LT(right_errors.back(), 0.2);
  EXPECT_GT(database_errors[4], 3 * right_errors[4])
      << "database " << database_errors[4] << ", right " << right_errors[4];
  EXPECT_EQ(with_right.cameras.at(1).params, right.at(1).params);
  EXPECT_EQ(with_database.cameras.at(1).params, wrong.params);
}

TEST(ViewGraphBuilder, ComponentSplitByFailedPosesFallsBackToAllPairs) {
  // Candidate components: A = 1-2-3-4-5-6 (6 images) and B = 7-8-9-10 (4).
  // B's poses are not derived while A stays the largest; here the pose of
  // 3-4 fails (no geometry stored, 6 matches), A splits into two halves of 3
  // and B is the largest component, as if every pose had been derived.
  SyntheticDatabase db(10);
  const int kCal = TwoViewGeometry::CALIBRATED;
  db.AddPair(1, 2, 100, kCal);
  db.AddPair(2, 3, 100, kCal);
  db.AddPair(3, 4, 6, kCal);
  TwoViewGeometry& failing = db.contents_.two_view_geometries.back();
  failing.E.setZero();
  failing.F.setZero();
  failing.H.setZero();
  db.AddPair(4, 5, 100, kCal);
  db.AddPair(5, 6, 100, kCal);
  db.AddPair(7, 8, 100, kCal);
  db.AddPair(8, 9, 100, kCal);
  db.AddPair(9, 10, 100, kCal);
  ViewGraphBuilderOptions options;
  options.min_num_inliers = 5;
  ViewGraphSummary summary;
  ViewGraph view_graph = BuildViewGraph(db.contents_, options, &summary);
  EXPECT_EQ(summary.num_dropped["relative pose failed"], 1);
  EXPECT_EQ(summary.num_dropped["outside the largest component"], 4);
  EXPECT_EQ(summary.num_components, 3);
  EXPECT_EQ(summary.num_images_in_component, 4);
  ASSERT_EQ(view_graph.pairs.size(), 3u);
  for (const ImagePairGeometry& pair : view_graph.pairs) {
    EXPECT_GE(pair.image_id1, 7u);
  }
  // With 3-4 intact, A is kept and B's three pairs are never derived.
  SyntheticDatabase intact(10);
  intact.AddPair(1, 2, 100, kCal);
  intact.AddPair(2, 3, 100, kCal);
  intact.AddPair(3, 4, 100, kCal);
  intact.AddPair(4, 5, 100, kCal);
  intact.AddPair(5, 6, 100, kCal);
  intact.AddPair(7, 8, 100, kCal);
  intact.AddPair(8, 9, 100, kCal);
  intact.AddPair(9, 10, 100, kCal);
  view_graph = BuildViewGraph(intact.contents_, options, &summary);
  EXPECT_EQ(summary.num_dropped.count("relative pose failed"), 0u);
  EXPECT_EQ(summary.num_dropped["outside the largest component"], 3);
  EXPECT_EQ(summary.num_components, 2);
  EXPECT_EQ(summary.num_images_in_component, 6);
  EXPECT_EQ(view_graph.pairs.size(), 5u);
}

TEST(ViewGraphBuilder, OptionsCheck) {
  ViewGraphBuilderOptions options;
  EXPECT_NO_THROW(options.Check());
  EXPECT_EQ(options.DropConfigs().size(), 4u);
  options.drop_configs = "WATERMARK,BOGUS";
  EXPECT_THROW(options.Check(), InputError);
  options = ViewGraphBuilderOptions();
  options.min_num_inliers = -1;
  EXPECT_THROW(options.Check(), InputError);
  options = ViewGraphBuilderOptions();
  options.min_inlier_ratio = 2;
  EXPECT_THROW(options.Check(), InputError);
}

}  // namespace
}  // namespace colmap_irav4
