// The mapper's stages one by one, in-process, on a small synthetic scene with
// known poses: what each stage leaves in the GlobalMapper's state, and that
// Run() is exactly the stages in order.

#include <algorithm>
#include <functional>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>
#include <utility>

#include <gtest/gtest.h>

#include "colmap_irav4/eval/synthetic_scene.h"
#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/pipeline/global_mapper.h"
#include "colmap_irav4/scene/reconstruction_utils.h"
#include "tests/test_utils/scene_test_utils.h"

namespace colmap_irav4 {
namespace {

// A synthetic scene as the mapper sees it: a database (cameras, images,
// keypoints, inlier matches) and the view graph's pairs (relative poses from
// the truth, 0.3 deg of rotation noise; one pair's rotation 40 deg off).
struct StageScene {
  SyntheticScene scene;
  DatabaseContents database;
  std::vector<image_t> images;
  std::vector<ImagePairGeometry> pairs;
  image_pair_t wrong_pair = 0;
};

StageScene MakeStageScene() {
  StageScene s;
  SyntheticSceneOptions options;
  options.num_images = 8;
  options.num_points = 600;
  options.visibility = 0.8;
  options.noise_px = 0.5;
  options.seed = 3;
  s.scene = GenerateSyntheticScene(options);
  const Reconstruction& truth = s.scene.truth;
  s.database.path = "synthetic";
  s.database.cameras = truth.cameras;
  for (const auto& [image_id, image] : truth.images) {
    DatabaseImage& row = s.database.images[image_id];
    row.image_id = image_id;
    row.name = image.name;
    row.camera_id = image.camera_id;
    FeatureKeypoints& keypoints = s.database.keypoints[image_id];
    for (const Point2D& point2D : image.points2D) {
      keypoints.push_back(point2D.xy.cast<float>());
    }
    s.images.push_back(image_id);
  }
  std::mt19937_64 rng(5);
  for (const ImagePairMatches& matches : s.scene.matches) {
    if (matches.matches.size() < 30) continue;
    TwoViewGeometry geometry;
    geometry.image_id1 = matches.image_id1;
    geometry.image_id2 = matches.image_id2;
    geometry.config = TwoViewGeometry::CALIBRATED;
    for (const auto& [idx1, idx2] : matches.matches) {
      geometry.inlier_matches.push_back(FeatureMatch{idx1, idx2});
    }
    s.database.two_view_geometries.push_back(geometry);

    const Rigid3d& pose1 = truth.images.at(matches.image_id1).cam_from_world;
    const Rigid3d& pose2 = truth.images.at(matches.image_id2).cam_from_world;
    const Eigen::Matrix3d R1 = pose1.rotation.toRotationMatrix();
    const Eigen::Matrix3d R2 = pose2.rotation.toRotationMatrix();
    ImagePairGeometry pair;
    pair.image_id1 = matches.image_id1;
    pair.image_id2 = matches.image_id2;
    pair.R = RandomRotationWithAngle(DegToRad(0.3), &rng) * R2 * R1.transpose();
    pair.t = (pose2.translation - R2 * R1.transpose() * pose1.translation)
                 .normalized();
    pair.num_inliers = static_cast<int>(matches.matches.size());
    pair.config = TwoViewGeometry::CALIBRATED;
    s.pairs.push_back(pair);
  }
  // One wrong relative rotation: the rotation filter must drop it.
  ImagePairGeometry& wrong = s.pairs[s.pairs.size() / 2];
  wrong.R = RandomRotationWithAngle(DegToRad(40.0), &rng) * wrong.R;
  s.wrong_pair = ImagePairToPairId(wrong.image_id1, wrong.image_id2);
  return s;
}

GlobalMapperOptions TestOptions() {
  GlobalMapperOptions options;
  // One thread: Ceres' results are then bit-identical between two runs.
  options.num_threads = 1;
  options.progress = 0;
  return options;
}

double MaxRelativeRotationErrorDeg(
    const std::map<image_t, Eigen::Matrix3d>& rotations,
    const Reconstruction& truth) {
  double max_error = 0;
  for (const auto& [id1, R1] : rotations) {
    for (const auto& [id2, R2] : rotations) {
      if (id2 <= id1) continue;
      const Eigen::Matrix3d T1 =
          truth.images.at(id1).cam_from_world.rotation.toRotationMatrix();
      const Eigen::Matrix3d T2 =
          truth.images.at(id2).cam_from_world.rotation.toRotationMatrix();
      max_error = std::max(max_error, AngularDistanceDeg(R2 * R1.transpose(),
                                                         T2 * T1.transpose()));
    }
  }
  return max_error;
}

// The keypoints a held mapper releases come back exactly: the database's
// keypoints with the links of the points' tracks; an image whose keypoints
// are not the database's keeps them; the refinement goes on from a resumed
// mapper as from one never suspended.
TEST(GlobalMapperStages, SuspendedKeypointsComeBackExactly) {
  StageScene s = MakeStageScene();
  const GlobalMapperOptions options = TestOptions().ForStages(s.images.size());
  GlobalMapper mapper(options, s.database, s.database.cameras, s.images,
                      s.pairs);
  GlobalMapper untouched(options, s.database, s.database.cameras, s.images,
                         s.pairs);
  ASSERT_TRUE(mapper.RotationAveraging() && mapper.RotationFilter() &&
              mapper.BuildTracks() && mapper.Positioning());
  ASSERT_TRUE(untouched.RotationAveraging() && untouched.RotationFilter() &&
              untouched.BuildTracks() && untouched.Positioning());
  // One image's keypoint moved off the database's: that image keeps them.
  const image_t moved = s.images[2];
  mapper.reconstruction().images.at(moved).points2D[0].xy.x() += 0.25;
  const Reconstruction before = mapper.reconstruction();
  size_t num_linked = 0;
  for (const auto& [image_id, image] : before.images) {
    for (const Point2D& point2D : image.points2D) {
      num_linked += point2D.point3D_id != kInvalidPoint3DId ? 1 : 0;
    }
  }
  ASSERT_GT(num_linked, 100u);

  mapper.SuspendKeypoints();
  EXPECT_TRUE(mapper.keypoints_suspended());
  for (const auto& [image_id, image] : mapper.reconstruction().images) {
    EXPECT_EQ(
        image.points2D.size(),
        image_id == moved ? before.images.at(image_id).points2D.size() : 0u)
        << image_id;
  }
  // Poses and points stay.
  EXPECT_EQ(mapper.reconstruction().points3D.size(), before.points3D.size());
  mapper.ResumeKeypoints();
  EXPECT_FALSE(mapper.keypoints_suspended());
  for (const auto& [image_id, image] : before.images) {
    const std::vector<Point2D>& again =
        mapper.reconstruction().images.at(image_id).points2D;
    ASSERT_EQ(again.size(), image.points2D.size()) << image_id;
    for (size_t k = 0; k < again.size(); ++k) {
      EXPECT_EQ(again[k].xy, image.points2D[k].xy);
      EXPECT_EQ(again[k].scale, image.points2D[k].scale);
      EXPECT_EQ(again[k].point3D_id, image.points2D[k].point3D_id);
    }
  }

  // Refined after a suspension: the same model as the mapper never
  // suspended (the moved keypoint put back first).
  mapper.reconstruction().images.at(moved).points2D[0].xy.x() -= 0.25;
  mapper.SuspendKeypoints();
  mapper.ResumeKeypoints();
  ASSERT_TRUE(mapper.IterativeBundleAdjustment());
  ASSERT_TRUE(untouched.IterativeBundleAdjustment());
  ASSERT_EQ(mapper.reconstruction().points3D.size(),
            untouched.reconstruction().points3D.size());
  for (const auto& [image_id, image] : untouched.reconstruction().images) {
    const Image& other = mapper.reconstruction().images.at(image_id);
    EXPECT_EQ(other.cam_from_world.translation,
              image.cam_from_world.translation);
  }

  // Solve() resumes first: a solved mapper suspended is whole after it, and
  // holds no tracks once refined.
  GlobalMapper solved(options, s.database, s.database.cameras, s.images,
                      s.pairs);
  ASSERT_TRUE(solved.Solve());
  EXPECT_TRUE(solved.tracks().empty());
  const Reconstruction whole = solved.reconstruction();
  solved.SuspendKeypoints();
  EXPECT_TRUE(solved.keypoints_suspended());
  ASSERT_TRUE(solved.Solve());
  EXPECT_FALSE(solved.keypoints_suspended());
  for (const auto& [image_id, image] : whole.images) {
    const std::vector<Point2D>& again =
        solved.reconstruction().images.at(image_id).points2D;
    ASSERT_EQ(again.size(), image.points2D.size());
    for (size_t k = 0; k < again.size(); ++k) {
      EXPECT_EQ(again[k].point3D_id, image.points2D[k].point3D_id);
    }
  }
}

TEST(GlobalMapperStages, EachStageLeavesItsResultInTheMapper) {
  const StageScene s = MakeStageScene();
  const size_t num_pairs = s.pairs.size();
  ASSERT_GE(num_pairs, 20u);
  GlobalMapper mapper(TestOptions().ForStages(s.images.size()), s.database,
                      s.database.cameras, s.images, s.pairs);
  EXPECT_EQ(mapper.num_component_pairs(), num_pairs);

  ASSERT_TRUE(mapper.RotationAveraging());
  ASSERT_EQ(mapper.rotations().size(), s.images.size());
  EXPECT_LT(MaxRelativeRotationErrorDeg(mapper.rotations(), s.scene.truth),
            1.0);
  EXPECT_EQ(mapper.stages().back().name, "rotation averaging (irav4)");

  ASSERT_TRUE(mapper.RotationFilter());
  EXPECT_EQ(mapper.pairs().size(), num_pairs - 1);
  for (const ImagePairGeometry& pair : mapper.pairs()) {
    EXPECT_NE(ImagePairToPairId(pair.image_id1, pair.image_id2), s.wrong_pair);
  }
  EXPECT_EQ(mapper.stages().back().figures[1].first,
            "pairs dropped (rotation)");
  EXPECT_EQ(mapper.stages().back().figures[1].second, 1.0);

  ASSERT_TRUE(mapper.BuildTracks());
  EXPECT_GT(mapper.tracks().size(), 400u);
  EXPECT_EQ(mapper.reconstruction().images.size(), s.images.size());
  // Global positioning's tracks are the model's points before positioning.
  EXPECT_GT(mapper.reconstruction().points3D.size(), 0u);
  EXPECT_LE(mapper.reconstruction().points3D.size(), mapper.tracks().size());

  ASSERT_TRUE(mapper.Positioning());
  EXPECT_LT(test::MaxRelativeCenterError(mapper.reconstruction(), s.scene.truth,
                                         10.0),
            0.02);

  ASSERT_TRUE(mapper.IterativeBundleAdjustment());
  std::vector<std::string> names;
  for (const StageReport& stage : mapper.stages()) names.push_back(stage.name);
  EXPECT_EQ(names,
            (std::vector<std::string>{
                "rotation averaging (irav4)", "rotation filter", "tracks",
                "global_positioning", "bundle adjustment 1", "retriangulation",
                "two-view check", "bundle adjustment 2"}));
  // The adjustments, the two-view check's among them, say how their solves
  // went (summary.json).
  for (const StageReport& stage : mapper.stages()) {
    if (stage.name != "bundle adjustment 1" && stage.name != "two-view check" &&
        stage.name != "bundle adjustment 2") {
      continue;
    }
    std::map<std::string, double> figures(stage.figures.begin(),
                                          stage.figures.end());
    EXPECT_GE(figures["iterations"], 1) << stage.name;
    EXPECT_GE(figures["solves"], 1) << stage.name;
  }
  // 0.5 px keypoint noise: mean reprojection error near 0.5 * sqrt(pi/2).
  const double error = UpdateReprojectionErrors(&mapper.reconstruction());
  EXPECT_LT(error, 0.8);
  EXPECT_GT(error, 0.3);
  // Retriangulation completed the tracks positioning did not use.
  EXPECT_GT(mapper.reconstruction().points3D.size(),
            0.9 * mapper.tracks().size());
  EXPECT_LT(test::MaxRelativeCenterError(mapper.reconstruction(), s.scene.truth,
                                         10.0),
            0.002);

  ASSERT_TRUE(mapper.Finalize());
  EXPECT_EQ(mapper.stages().back().name, "normalisation");
  EXPECT_EQ(mapper.reconstruction().images.size(), s.images.size());

  // Without images every point is grey.
  EXPECT_EQ(mapper.ColorPoints(""), 0);
  for (const auto& [point3D_id, point] : mapper.reconstruction().points3D) {
    ASSERT_EQ(point.color.cast<int>(), Eigen::Vector3i(128, 128, 128));
  }
  EXPECT_EQ(mapper.stages().back().name, "colours (grey: no --image_path)");
}

TEST(GlobalMapperStages, MaxNumTracksCapsTheTracksAndSaysSo) {
  const StageScene s = MakeStageScene();
  GlobalMapper uncapped(TestOptions().ForStages(s.images.size()), s.database,
                        s.database.cameras, s.images, s.pairs);
  ASSERT_TRUE(uncapped.RotationAveraging() && uncapped.RotationFilter() &&
              uncapped.BuildTracks());
  const size_t num_tracks = uncapped.tracks().size();
  ASSERT_GT(num_tracks, 400u);

  GlobalMapperOptions options = TestOptions();
  options.max_num_tracks = 300;
  GlobalMapper mapper(options.ForStages(s.images.size()), s.database,
                      s.database.cameras, s.images, s.pairs);
  ASSERT_TRUE(mapper.RotationAveraging() && mapper.RotationFilter() &&
              mapper.BuildTracks());
  EXPECT_EQ(mapper.tracks().size(), 300u);
  const StageReport& stage = mapper.stages().back();
  ASSERT_EQ(stage.name, "tracks");
  EXPECT_EQ(stage.figures.back().first, "dropped (max_num_tracks)");
  EXPECT_EQ(stage.figures.back().second, num_tracks - 300.0);
  // The longest tracks are the ones kept.
  size_t shortest_kept = mapper.tracks().front().size();
  for (const Track& track : mapper.tracks()) {
    shortest_kept = std::min(shortest_kept, track.size());
  }
  size_t num_longer = 0;
  for (const Track& track : uncapped.tracks()) {
    num_longer += track.size() > shortest_kept ? 1 : 0;
  }
  EXPECT_LE(num_longer, 300u);
  // The capped model is still mapped completely.
  ASSERT_TRUE(mapper.Positioning() && mapper.IterativeBundleAdjustment() &&
              mapper.Finalize());
  EXPECT_EQ(mapper.reconstruction().images.size(), s.images.size());
  EXPECT_LE(mapper.reconstruction().points3D.size(), 300u);
}

TEST(GlobalMapperStages, SolveIsTheStagesInOrder) {
  const StageScene s = MakeStageScene();
  GlobalMapper by_stage(TestOptions().ForStages(s.images.size()), s.database,
                        s.database.cameras, s.images, s.pairs);
  ASSERT_TRUE(by_stage.RotationAveraging() && by_stage.RotationFilter() &&
              by_stage.BuildTracks() && by_stage.Positioning() &&
              by_stage.IterativeBundleAdjustment() && by_stage.Finalize());
  GlobalMapper whole(TestOptions().ForStages(s.images.size()), s.database,
                     s.database.cameras, s.images, s.pairs);
  ASSERT_TRUE(whole.Solve());
  ASSERT_EQ(whole.stages().size(), by_stage.stages().size());
  for (size_t k = 0; k < whole.stages().size(); ++k) {
    EXPECT_EQ(whole.stages()[k].name, by_stage.stages()[k].name);
    ASSERT_EQ(whole.stages()[k].figures.size(),
              by_stage.stages()[k].figures.size());
    for (size_t f = 0; f < whole.stages()[k].figures.size(); ++f) {
      EXPECT_EQ(whole.stages()[k].figures[f].first,
                by_stage.stages()[k].figures[f].first);
      EXPECT_NEAR(whole.stages()[k].figures[f].second,
                  by_stage.stages()[k].figures[f].second, 1e-9);
    }
  }
  ASSERT_EQ(whole.reconstruction().images.size(),
            by_stage.reconstruction().images.size());
  for (const auto& [image_id, image] : whole.reconstruction().images) {
    const Image& other = by_stage.reconstruction().images.at(image_id);
    // Equal up to floating-point noise (Eigen's vectorised sums may differ in
    // the last bits between two runs).
    EXPECT_LT(
        (image.cam_from_world.translation - other.cam_from_world.translation)
            .norm(),
        1e-9);
  }
}

// A matcher that keeps a quarter of each pair's matches splits points over
// several tracks; with point merging on, the mapper joins them again after
// retriangulation (its stage reports the merges): fewer, longer points on
// about the same observations, and the poses as good.
TEST(GlobalMapperStages, PointMergingJoinsPointsOfSplitTracks) {
  StageScene s = MakeStageScene();
  std::mt19937_64 rng(11);
  for (TwoViewGeometry& geometry : s.database.two_view_geometries) {
    std::vector<FeatureMatch> kept;
    for (const FeatureMatch& match : geometry.inlier_matches) {
      if (std::bernoulli_distribution(0.25)(rng)) kept.push_back(match);
    }
    geometry.inlier_matches = kept;
  }
  GlobalMapperOptions options = TestOptions();
  GlobalMapper apart(options.ForStages(s.images.size()), s.database,
                     s.database.cameras, s.images, s.pairs);
  ASSERT_TRUE(apart.Solve());
  options.point_merging.enabled = true;
  GlobalMapper merged(options.ForStages(s.images.size()), s.database,
                      s.database.cameras, s.images, s.pairs);
  ASSERT_TRUE(merged.Solve());
  double num_merges = -1;
  for (const StageReport& stage : merged.stages()) {
    if (stage.name != "point merging") continue;
    for (const auto& [name, value] : stage.figures) {
      if (name == "points merged") num_merges = value;
    }
  }
  for (const StageReport& stage : apart.stages()) {
    EXPECT_NE(stage.name, "point merging");
  }
  const Reconstruction& a = apart.reconstruction();
  const Reconstruction& m = merged.reconstruction();
  EXPECT_GT(num_merges, 0.1 * static_cast<double>(a.points3D.size()));
  EXPECT_LT(m.points3D.size(), a.points3D.size());
  EXPECT_GT(MeanTrackLength(m), 1.1 * MeanTrackLength(a));
  EXPECT_GT(static_cast<double>(NumObservations(m)),
            0.98 * static_cast<double>(NumObservations(a)));
  // Every merged point holds one true point's keypoints.
  size_t num_impure = 0;
  for (const auto& [point3D_id, point] : m.points3D) {
    std::set<point3D_t> truths;
    for (const TrackElement& element : point.track) {
      truths.insert(s.scene.truth.images.at(element.image_id)
                        .points2D[element.point2D_idx]
                        .point3D_id);
    }
    num_impure += truths.size() > 1;
  }
  EXPECT_LE(num_impure, m.points3D.size() / 100);
  EXPECT_EQ(m.images.size(), a.images.size());
}

TEST(GlobalMapperStages, SolveGoesOnFromRotationsAveragedBefore) {
  // The part merge looks at a mapper's rotations before solving it
  // (pipeline/component_mapper.h): Solve() must not average them again.
  const StageScene s = MakeStageScene();
  GlobalMapper probed(TestOptions().ForStages(s.images.size()), s.database,
                      s.database.cameras, s.images, s.pairs);
  ASSERT_TRUE(probed.RotationAveraging());
  ASSERT_TRUE(probed.Solve());
  GlobalMapper whole(TestOptions().ForStages(s.images.size()), s.database,
                     s.database.cameras, s.images, s.pairs);
  ASSERT_TRUE(whole.Solve());
  // The same stages, rotation averaging once.
  ASSERT_EQ(probed.stages().size(), whole.stages().size());
  for (size_t k = 0; k < whole.stages().size(); ++k) {
    EXPECT_EQ(probed.stages()[k].name, whole.stages()[k].name);
  }
  ASSERT_EQ(probed.rotations().size(), whole.rotations().size());
  for (const auto& [image_id, R] : whole.rotations()) {
    ASSERT_TRUE(probed.rotations().count(image_id));
    EXPECT_LT(AngularDistanceDeg(R, probed.rotations().at(image_id)), 1e-9);
  }
  ASSERT_EQ(probed.reconstruction().images.size(),
            whole.reconstruction().images.size());
  for (const auto& [image_id, image] : whole.reconstruction().images) {
    const Image& other = probed.reconstruction().images.at(image_id);
    EXPECT_LT(
        (image.cam_from_world.translation - other.cam_from_world.translation)
            .norm(),
        1e-9);
  }
}

// The largest distance between the same image's camera centre in two models
// (infinity when their images differ).
double MaxCenterDifference(const Reconstruction& a, const Reconstruction& b) {
  if (a.images.size() != b.images.size()) {
    return std::numeric_limits<double>::infinity();
  }
  double max_difference = 0;
  for (const auto& [image_id, image] : a.images) {
    const auto other = b.images.find(image_id);
    if (other == b.images.end()) return std::numeric_limits<double>::infinity();
    max_difference = std::max(
        max_difference,
        (image.ProjectionCenter() - other->second.ProjectionCenter()).norm());
  }
  return max_difference;
}

TEST(GlobalMapperStages, SameSeedSameModelOtherSeedOtherStart) {
  const StageScene s = MakeStageScene();
  GlobalMapperOptions options = TestOptions();
  options.seed = 11;
  // --Mapper.seed reaches every stage that draws random numbers.
  const GlobalMapperOptions stages = options.ForStages(s.images.size());
  EXPECT_EQ(stages.rotation_averaging.irav4.seed, 11);
  EXPECT_EQ(stages.global_positioning.random_seed, 11u);
  EXPECT_EQ(stages.translation_averaging.random_seed, 11u);
  EXPECT_EQ(stages.triangulation.random_seed, 11u);

  GlobalMapper first(options.ForStages(s.images.size()), s.database,
                     s.database.cameras, s.images, s.pairs);
  GlobalMapper second(options.ForStages(s.images.size()), s.database,
                      s.database.cameras, s.images, s.pairs);
  ASSERT_TRUE(first.Solve());
  ASSERT_TRUE(second.Solve());
  const Reconstruction& a = first.reconstruction();
  const Reconstruction& b = second.reconstruction();
  // The same model bit for bit, though the two live at other addresses
  // (as between two runs of the program: MapperE2E.SameSeedSameModelFiles).
  test::ExpectSameBits(a, b);

  // Another seed: global positioning starts elsewhere (random centres and
  // points) and stops elsewhere within its loose tolerance (2e-7 here, far
  // above the same seed's zero), as accurate.
  GlobalMapperOptions other_options = options;
  other_options.seed = 12;
  GlobalMapper same_start(options.ForStages(s.images.size()), s.database,
                          s.database.cameras, s.images, s.pairs);
  GlobalMapper other_start(other_options.ForStages(s.images.size()), s.database,
                           s.database.cameras, s.images, s.pairs);
  for (GlobalMapper* mapper : {&same_start, &other_start}) {
    ASSERT_TRUE(mapper->RotationAveraging() && mapper->RotationFilter() &&
                mapper->BuildTracks() && mapper->Positioning());
  }
  const double difference = MaxCenterDifference(same_start.reconstruction(),
                                                other_start.reconstruction());
  RecordProperty("positioning_difference", testing::PrintToString(difference));
  EXPECT_GT(difference, 1e-8);
  EXPECT_LT(test::MaxRelativeCenterError(other_start.reconstruction(),
                                         s.scene.truth, 10.0),
            0.02);
}

TEST(GlobalMapperStages, StagesSkippedByOptionsAndFailureReason) {
  const StageScene s = MakeStageScene();
  GlobalMapperOptions options = TestOptions();
  options.skip_bundle_adjustment = true;
  options.skip_normalization = true;
  GlobalMapper mapper(options.ForStages(s.images.size()), s.database,
                      s.database.cameras, s.images, s.pairs);
  ASSERT_TRUE(mapper.Solve());
  std::vector<std::string> names;
  for (const StageReport& stage : mapper.stages()) names.push_back(stage.name);
  EXPECT_EQ(names,
            (std::vector<std::string>{
                "rotation averaging (irav4)", "rotation filter", "tracks",
                "global_positioning", "retriangulation", "final filtering"}));

  // More images needed than the component has: the rotation filter stops.
  options = TestOptions();
  options.min_model_size = static_cast<int>(s.images.size()) + 1;
  GlobalMapper too_small(options.ForStages(s.images.size()), s.database,
                         s.database.cameras, s.images, s.pairs);
  EXPECT_FALSE(too_small.Solve());
  EXPECT_NE(too_small.failure().find("images with consistent rotations"),
            std::string::npos)
      << too_small.failure();
  EXPECT_EQ(too_small.stages().size(), 2u);
}

// A stand-in whose bundle adjustments of the named stages report a failure
// after they ran (the model moved, as after a failed solve); it keeps the
// model each adjustment started from.
class FailingAdjustmentMapper : public GlobalMapper {
 public:
  FailingAdjustmentMapper(const StageScene& s, std::set<std::string> failing)
      : GlobalMapper(TestOptions().ForStages(s.images.size()), s.database,
                     s.database.cameras, s.images, s.pairs),
        failing_(std::move(failing)) {}

  std::map<std::string, Reconstruction> started_from;

 protected:
  bool RunAdjustment(const std::string& stage,
                     const std::function<bool()>& adjust) override {
    started_from[stage] = reconstruction();
    const bool success = adjust();
    return success && failing_.count(stage) == 0;
  }

 private:
  const std::set<std::string> failing_;
};

// The 999-image model of issue 23/24 was lost to the two-view check's
// failed bundle adjustment after bundle adjustment 1 had converged: a
// later failed adjustment keeps the model as it was before it.
TEST(GlobalMapperStages, FailedLaterAdjustmentKeepsTheModelBeforeIt) {
  const StageScene s = MakeStageScene();
  FailingAdjustmentMapper mapper(s, {"two-view check", "bundle adjustment 2"});
  ASSERT_TRUE(mapper.RotationAveraging() && mapper.RotationFilter() &&
              mapper.BuildTracks() && mapper.Positioning());
  ASSERT_TRUE(mapper.IterativeBundleAdjustment()) << mapper.failure();
  ASSERT_EQ(mapper.started_from.size(), 3u);
  // Both failed adjustments left the model as they found it: the
  // retriangulated model after bundle adjustment 1.
  test::ExpectSameBits(mapper.reconstruction(),
                       mapper.started_from.at("two-view check"));
  test::ExpectSameBits(mapper.reconstruction(),
                       mapper.started_from.at("bundle adjustment 2"));
  // Not the model bundle adjustment 1 started from (that one converged).
  EXPECT_GT(MaxCenterDifference(mapper.reconstruction(),
                                mapper.started_from.at("bundle adjustment 1")),
            1e-6);
  // The stages say so (summary.json), the others do not.
  std::vector<std::string> warned;
  for (const StageReport& stage : mapper.stages()) {
    for (const auto& [name, value] : stage.figures) {
      if (name ==
          "warning: bundle adjustment failed, model kept as before it") {
        EXPECT_EQ(value, 1.0);
        warned.push_back(stage.name);
      }
    }
  }
  EXPECT_EQ(warned, (std::vector<std::string>{"two-view check",
                                              "bundle adjustment 2"}));
  EXPECT_LT(test::MaxRelativeCenterError(mapper.reconstruction(), s.scene.truth,
                                         10.0),
            0.01);
  ASSERT_TRUE(mapper.Finalize());
  EXPECT_EQ(mapper.reconstruction().images.size(), s.images.size());

  // Before any adjustment succeeded there is no model to keep: the
  // component fails, as before.
  FailingAdjustmentMapper first_fails(s, {"bundle adjustment 1"});
  EXPECT_FALSE(first_fails.Solve());
  EXPECT_EQ(first_fails.failure(), "bundle adjustment failed");
}

// An image tied to the scene by one false pair only (random matches, a
// relative pose 150 deg off the truth), as image 173 of the V2 300-image
// courtyard (seed 2): rotation averaging follows the pair, positioning places
// the image on its matches, and the filters remove every one of them. An
// image no point is seen in has a pose nothing supports; it must leave the
// model instead of being written turned.
TEST(GlobalMapperStages, AnImageOnlyAFalsePairHoldsLeavesTheModel) {
  StageScene s = MakeStageScene();
  constexpr point2D_t kNumStrayMatches = 30;
  const image_t stray = s.images.back() + 1;
  const image_t partner = s.images.front();
  const Camera& camera = s.database.cameras.begin()->second;
  DatabaseImage& row = s.database.images[stray];
  row.image_id = stray;
  row.name = "stray.jpg";
  row.camera_id = camera.camera_id;
  std::mt19937_64 rng(7);
  // Keypoints in the left quarter: far from the principal point, so that no
  // pose (not even one far away, where every point projects near the centre)
  // fits them by chance.
  std::uniform_real_distribution<double> x(0.0, 0.25 * camera.width);
  std::uniform_real_distribution<double> y(0.0, camera.height);
  FeatureKeypoints& keypoints = s.database.keypoints[stray];
  for (int k = 0; k < 200; ++k) {
    keypoints.push_back(Eigen::Vector2f(x(rng), y(rng)));
  }
  s.images.push_back(stray);
  TwoViewGeometry geometry;
  geometry.image_id1 = partner;
  geometry.image_id2 = stray;
  geometry.config = TwoViewGeometry::CALIBRATED;
  const size_t num_partner_keypoints = s.database.keypoints.at(partner).size();
  for (point2D_t k = 0; k < kNumStrayMatches; ++k) {
    geometry.inlier_matches.push_back(FeatureMatch{
        static_cast<point2D_t>((k * 7) % num_partner_keypoints), k});
  }
  s.database.two_view_geometries.push_back(geometry);
  ImagePairGeometry pair;
  pair.image_id1 = partner;
  pair.image_id2 = stray;
  pair.R = RandomRotationWithAngle(DegToRad(150.0), &rng);
  pair.t = Eigen::Vector3d(0.3, -0.2, 1.0).normalized();
  pair.num_inliers = kNumStrayMatches;
  pair.config = TwoViewGeometry::CALIBRATED;
  s.pairs.push_back(pair);

  // Kept (as before Filter.min_num_observations_per_image was 1): the image
  // is in the model, seen in no point, its pose the false pair's.
  GlobalMapperOptions keep_options = TestOptions();
  keep_options.filtering.min_num_observations_per_image = 0;
  GlobalMapper keep(keep_options.ForStages(s.images.size()), s.database,
                    s.database.cameras, s.images, s.pairs);
  ASSERT_TRUE(keep.Solve());
  ASSERT_EQ(keep.reconstruction().images.count(stray), 1u);
  for (const Point2D& point2D :
       keep.reconstruction().images.at(stray).points2D) {
    EXPECT_EQ(point2D.point3D_id, kInvalidPoint3DId);
  }

  GlobalMapper mapper(TestOptions().ForStages(s.images.size()), s.database,
                      s.database.cameras, s.images, s.pairs);
  ASSERT_TRUE(mapper.Solve());
  const Reconstruction& model = mapper.reconstruction();
  EXPECT_EQ(model.images.count(stray), 0u);
  // Every image of the scene itself stays, and every image in the model is
  // seen in some point.
  EXPECT_EQ(model.images.size(), s.images.size() - 1);
  for (const auto& [image_id, image] : model.images) {
    int num_observations = 0;
    for (const Point2D& point2D : image.points2D) {
      num_observations += point2D.point3D_id != kInvalidPoint3DId;
    }
    EXPECT_GT(num_observations, 0) << image.name;
  }
  // The stages say so.
  double num_filtered = 0;
  for (const StageReport& stage : mapper.stages()) {
    for (const auto& [name, value] : stage.figures) {
      if (name == "images filtered") num_filtered += value;
    }
  }
  EXPECT_EQ(num_filtered, 1.0);
}

// The scene with its last three images a part tied to the rest by the few
// points whose id is a multiple of 100 (their matches across kept, every
// other match across dropped): with Mapper.weak_part_min_shared_points the
// part is adjusted apart from the rest (no point seen from both), or, when
// smaller than min_model_size, leaves the model; without it the few points
// tie the two.
TEST(GlobalMapperStages, WeaklyTiedPartIsLeftOutOfTheAdjustment) {
  StageScene s = MakeStageScene();
  const std::set<image_t> part(s.images.end() - 3, s.images.end());
  const Reconstruction& truth = s.scene.truth;
  auto across = [&](image_t a, image_t b) {
    return part.count(a) != part.count(b);
  };
  std::map<image_pair_t, int> num_kept;
  for (TwoViewGeometry& geometry : s.database.two_view_geometries) {
    if (!across(geometry.image_id1, geometry.image_id2)) continue;
    std::vector<FeatureMatch> kept;
    for (const FeatureMatch& match : geometry.inlier_matches) {
      const point3D_t point3D_id = truth.images.at(geometry.image_id1)
                                       .points2D[match.point2D_idx1]
                                       .point3D_id;
      if (point3D_id % 100 == 0) kept.push_back(match);
    }
    geometry.inlier_matches = kept;
    num_kept[ImagePairToPairId(geometry.image_id1, geometry.image_id2)] =
        static_cast<int>(kept.size());
  }
  std::vector<ImagePairGeometry> pairs;
  for (ImagePairGeometry pair : s.pairs) {
    if (across(pair.image_id1, pair.image_id2)) {
      const int num =
          num_kept[ImagePairToPairId(pair.image_id1, pair.image_id2)];
      if (num < 2) continue;
      pair.num_inliers = num;
    }
    pairs.push_back(pair);
  }
  s.pairs = pairs;

  // Whether some point is seen both from the part and from the rest.
  auto tied = [&](const Reconstruction& model) {
    for (const auto& [point3D_id, point3D] : model.points3D) {
      bool in_part = false, in_rest = false;
      for (const TrackElement& element : point3D.track) {
        (part.count(element.image_id) ? in_part : in_rest) = true;
      }
      if (in_part && in_rest) return true;
    }
    return false;
  };
  auto figure = [](const GlobalMapper& mapper, const std::string& name) {
    double total = 0;
    for (const StageReport& stage : mapper.stages()) {
      for (const auto& [figure_name, value] : stage.figures) {
        if (figure_name == name) total += value;
      }
    }
    return total;
  };

  GlobalMapper held(TestOptions().ForStages(s.images.size()), s.database,
                    s.database.cameras, s.images, s.pairs);
  ASSERT_TRUE(held.Solve());
  EXPECT_EQ(held.reconstruction().images.size(), s.images.size());
  EXPECT_TRUE(tied(held.reconstruction()));

  GlobalMapperOptions options = TestOptions();
  options.weak_part_min_shared_points = 15;
  GlobalMapper apart(options.ForStages(s.images.size()), s.database,
                     s.database.cameras, s.images, s.pairs);
  ASSERT_TRUE(apart.Solve());
  EXPECT_EQ(apart.reconstruction().images.size(), s.images.size());
  EXPECT_FALSE(tied(apart.reconstruction()));
  EXPECT_GT(figure(apart, "observations cut between parts"), 0.0);
  EXPECT_EQ(figure(apart, "images left out"), 0.0);
  // Each part is still a good model of its own: the relative rotations
  // within it are the truth's.
  for (const bool in_part : {false, true}) {
    std::map<image_t, Eigen::Matrix3d> rotations;
    for (const auto& [image_id, image] : apart.reconstruction().images) {
      if ((part.count(image_id) > 0) == in_part) {
        rotations[image_id] = image.cam_from_world.rotation.toRotationMatrix();
      }
    }
    EXPECT_LT(MaxRelativeRotationErrorDeg(rotations, truth), 0.5);
  }

  options.min_model_size = 4;
  GlobalMapper left_out(options.ForStages(s.images.size()), s.database,
                        s.database.cameras, s.images, s.pairs);
  ASSERT_TRUE(left_out.Solve());
  EXPECT_EQ(left_out.reconstruction().images.size(), s.images.size() - 3);
  for (const image_t image_id : part) {
    EXPECT_EQ(left_out.reconstruction().images.count(image_id), 0u);
  }
  EXPECT_EQ(figure(left_out, "images left out"), 3.0);
}

}  // namespace
}  // namespace colmap_irav4
