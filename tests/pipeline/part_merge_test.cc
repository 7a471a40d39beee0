#include "colmap_irav4/pipeline/part_merge.h"

#include <random>

#include <gtest/gtest.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/scene/camera_models.h"
#include "colmap_irav4/scene/reconstruction_utils.h"

namespace colmap_irav4 {
namespace {

// Two rigid parts of one model: images 1-4 (part A, in the true frame) and
// 5-8 (part B, turned by 120 deg and scaled by 2 in the model, as rotation
// averaging leaves a weak join), each with 40 points of its own. In the
// truth image b = 5 sees 20 points of part A and image 7 sees 20 more, so
// pairs (1, 5) and (3, 7) are true pairs across the join; (2, 6) is a false
// pair: a rotation 25 deg off and keypoints in 6 at random.
class PartMergeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    camera_.camera_id = 1;
    camera_.model_id = CameraModelNameToId("SIMPLE_PINHOLE");
    camera_.width = 1600;
    camera_.height = 1200;
    camera_.params = {1500, 800, 600};
    model_.cameras[1] = camera_;
    std::mt19937 random(7);
    std::uniform_real_distribution<double> unit(-1, 1);
    W_ = AngleAxisToRotation(Eigen::Vector3d(0, DegToRad(120), 0));
    for (image_t i = 1; i <= 8; ++i) {
      true_R_[i] = AngleAxisToRotation(
          DegToRad(2) *
          Eigen::Vector3d(unit(random), unit(random), unit(random)));
      true_C_[i] = Eigen::Vector3d(-1.5 + ((i - 1) % 4), i <= 4 ? 0 : 1, 0);
      Image& image = model_.images[i];
      image.image_id = i;
      image.camera_id = 1;
      // Part B in its own turned, scaled frame: x_B = 2 W x.
      const Eigen::Matrix3d R =
          i <= 4 ? true_R_[i] : Eigen::Matrix3d(true_R_[i] * W_.transpose());
      const Eigen::Vector3d C = i <= 4 ? true_C_[i] : 2 * W_ * true_C_[i];
      image.cam_from_world.rotation = Eigen::Quaterniond(R);
      image.cam_from_world.translation = -(R * C);
    }
    for (image_t part = 0; part < 2; ++part) {
      for (int k = 0; k < 40; ++k) {
        const Eigen::Vector3d X(2.5 * unit(random), 2 * unit(random),
                                10 + 2 * unit(random));
        std::vector<TrackElement> track;
        for (image_t i = 1 + 4 * part; i <= 4 + 4 * part; ++i) {
          track.push_back({i, Observe(i, X)});
        }
        const point3D_t id =
            AddPoint3D(part == 0 ? X : 2 * W_ * X, track, &model_);
        if (part == 0) points_a_.push_back({id, X});
      }
    }
    // The true pairs across: b's keypoints of A's points (not in the model:
    // the parts share no point).
    AddCrossPair(1, 5, 0, /*false_pair=*/false);
    AddCrossPair(3, 7, 20, /*false_pair=*/false);
    AddCrossPair(2, 6, 0, /*false_pair=*/true);
    std::uniform_real_distribution<double> random_pixel(100, 1100);
    for (auto& [index, keypoint] : random_keypoints_) {
      keypoint = Eigen::Vector2d(random_pixel(random), random_pixel(random));
      model_.images.at(index.first).points2D[index.second].xy = keypoint;
    }
  }

  // Adds a keypoint of image i at X's projection (true poses), returns it.
  point2D_t Observe(image_t i, const Eigen::Vector3d& X) {
    const Eigen::Vector3d x = true_R_[i] * (X - true_C_[i]);
    Image& image = model_.images.at(i);
    Point2D point;
    point.xy = CameraCameraToImage(camera_, x.hnormalized());
    image.points2D.push_back(point);
    return static_cast<point2D_t>(image.points2D.size() - 1);
  }

  // Pair (a, b) with 20 matches at A's points first_point.., and the
  // relative rotation true (else 25 deg off, keypoints in b at random).
  void AddCrossPair(image_t a, image_t b, int first_point, bool false_pair) {
    Eigen::Matrix3d R = true_R_[b] * true_R_[a].transpose();
    if (false_pair) {
      R = AngleAxisToRotation(Eigen::Vector3d(DegToRad(25), 0, 0)) * R;
    }
    AddPair(a, b, R, first_point, [&](const Eigen::Vector3d& X) {
      if (!false_pair) return Observe(b, X);
      model_.images.at(b).points2D.emplace_back();
      const auto idx_b =
          static_cast<point2D_t>(model_.images.at(b).points2D.size() - 1);
      random_keypoints_[{b, idx_b}] = Eigen::Vector2d::Zero();
      return idx_b;
    });
  }

  // Pair (a, b) whose 20 matches at A's points first_point.. fit a ghost
  // pose of b (as a random pair's or a repeated structure's do): b's
  // keypoints project A's points from `C_ghost` turned by `turn` from b's
  // true rotation, and the pair's rotation is the ghost's.
  void AddGhostPair(image_t a, image_t b, int first_point,
                    const Eigen::Matrix3d& turn,
                    const Eigen::Vector3d& C_ghost) {
    const Eigen::Matrix3d R_ghost = turn * true_R_[b];
    AddPair(a, b, R_ghost * true_R_[a].transpose(), first_point,
            [&](const Eigen::Vector3d& X) {
              Image& image = model_.images.at(b);
              Point2D point;
              point.xy = CameraCameraToImage(
                  camera_, (R_ghost * (X - C_ghost)).hnormalized());
              image.points2D.push_back(point);
              return static_cast<point2D_t>(image.points2D.size() - 1);
            });
  }

  // Pair (a, b) of rotation `R` (cam_b_from_cam_a) with 20 matches: a's
  // keypoints of A's points first_point.. and b's from `keypoint_b(X)`.
  template <typename KeypointB>
  void AddPair(image_t a, image_t b, const Eigen::Matrix3d& R, int first_point,
               KeypointB keypoint_b) {
    ImagePairGeometry pair;
    pair.image_id1 = a;
    pair.image_id2 = b;
    pair.R = R;
    pair.num_inliers = 20;
    pairs_.push_back(pair);
    TwoViewGeometry geometry;
    geometry.image_id1 = a;
    geometry.image_id2 = b;
    geometry.config = TwoViewGeometry::CALIBRATED;
    for (int k = first_point; k < first_point + 20; ++k) {
      const auto& [point3D_id, X] = points_a_[k];
      point2D_t idx_a = 0;
      for (const TrackElement& element : model_.points3D.at(point3D_id).track) {
        if (element.image_id == a) idx_a = element.point2D_idx;
      }
      geometry.inlier_matches.push_back({idx_a, keypoint_b(X)});
    }
    geometries_.push_back(geometry);
  }

  // The geometry's matches as (keypoint in image_id1, in image_id2).
  static std::vector<std::pair<point2D_t, point2D_t>> Matches(
      const TwoViewGeometry& geometry) {
    std::vector<std::pair<point2D_t, point2D_t>> matches;
    for (const FeatureMatch& match : geometry.inlier_matches) {
      matches.emplace_back(match.point2D_idx1, match.point2D_idx2);
    }
    return matches;
  }

  // Image_id2 of pair k placed from part A through image_id1 (with the
  // pair's rotation, or `R_ab`).
  CrossPairCheck CheckPair(size_t k, const Eigen::Matrix3d* R_ab = nullptr) {
    return CheckCrossPair(PartMergeOptions(), model_, {1, 2, 3, 4},
                          pairs_[k].image_id1, pairs_[k].image_id2,
                          R_ab != nullptr ? *R_ab : pairs_[k].R,
                          Matches(geometries_[k]));
  }

  Camera camera_;
  Reconstruction model_;
  Eigen::Matrix3d W_;
  std::map<image_t, Eigen::Matrix3d> true_R_;
  std::map<image_t, Eigen::Vector3d> true_C_;
  std::vector<std::pair<point3D_t, Eigen::Vector3d>> points_a_;
  std::map<std::pair<image_t, point2D_t>, Eigen::Vector2d> random_keypoints_;
  std::vector<ImagePairGeometry> pairs_;
  std::vector<TwoViewGeometry> geometries_;
};

TEST_F(PartMergeTest, TruePairIsConfirmedAndPlacesTheImage) {
  const CrossPairCheck check = CheckPair(0);
  EXPECT_EQ(check.num_points, 20);
  EXPECT_EQ(check.num_met, 20);
  EXPECT_TRUE(check.confirmed);
  // Placed in A's frame, which is the truth's.
  EXPECT_LT((check.center_b - true_C_[5]).norm(), 1e-6);
  EXPECT_LT(AngularDistanceDeg(check.R_b, true_R_[5]), 1e-6);
}

TEST_F(PartMergeTest, FalsePairIsNotConfirmed) {
  const CrossPairCheck check = CheckPair(2);
  EXPECT_EQ(check.num_points, 20);
  // Two rays always meet a centre; random ones no more.
  EXPECT_GE(check.num_met, 2);
  EXPECT_LT(check.num_met, 5);
  EXPECT_FALSE(check.confirmed);
}

TEST_F(PartMergeTest, PlanJoinsThePartsAndFindsTheFalsePair) {
  const PartMergePlan plan =
      PlanPartMerge(PartMergeOptions(), model_, {{1, 2, 3, 4}, {5, 6, 7, 8}},
                    pairs_, geometries_);
  EXPECT_EQ(plan.num_parts, 2);
  EXPECT_EQ(plan.num_pairs_across, 3);
  EXPECT_EQ(plan.num_confirmed, 2);
  EXPECT_EQ(plan.num_groups, 1);
  ASSERT_EQ(plan.group.size(), 2u);
  EXPECT_EQ(plan.group[1], 0);
  // Part B's rotations turned into A's frame are the true ones.
  for (image_t i = 5; i <= 8; ++i) {
    const Eigen::Matrix3d R =
        model_.images.at(i).cam_from_world.rotation.toRotationMatrix() *
        plan.correction[1];
    EXPECT_LT(AngularDistanceDeg(R, true_R_[i]), 1e-6) << i;
  }
  // Only the false pair contradicts the join, and the points refute it.
  EXPECT_EQ(plan.contradicted, (std::set<std::pair<image_t, image_t>>{{2, 6}}));
  EXPECT_EQ(plan.refuted, (std::set<std::pair<image_t, image_t>>{{2, 6}}));
}

TEST_F(PartMergeTest, PlanCountsTheDistinctPointsOfAJoin) {
  const PartMergePlan plan =
      PlanPartMerge(PartMergeOptions(), model_, {{1, 2, 3, 4}, {5, 6, 7, 8}},
                    pairs_, geometries_);
  ASSERT_EQ(plan.joins.size(), 1u);
  const PartJoin& join = plan.joins[0];
  EXPECT_EQ(join.part1, 0);
  EXPECT_EQ(join.part2, 1);
  // (1, 5) and (3, 7) meet 20 points of A each, none twice; b's keypoints
  // observe no point of B (the other direction meets none).
  EXPECT_EQ(join.num_pairs, 2);
  EXPECT_EQ(join.num_points, 40);
  ASSERT_GE(join.best_check, 0);
  EXPECT_TRUE(plan.checks[join.best_check].confirmed);
  EXPECT_EQ(plan.checks[join.best_check].num_met, 20);
}

TEST_F(PartMergeTest, JoinTurnsMeasureHowNewRotationsKeepTheJoin) {
  const std::vector<std::vector<image_t>> parts = {{1, 2, 3, 4}, {5, 6, 7, 8}};
  const PartMergePlan plan =
      PlanPartMerge(PartMergeOptions(), model_, parts, pairs_, geometries_);
  ASSERT_EQ(plan.num_groups, 1);
  // New rotations that keep the join: the truth in another world frame.
  const Eigen::Matrix3d frame =
      AngleAxisToRotation(Eigen::Vector3d(DegToRad(40), DegToRad(-70), 0));
  std::map<image_t, Eigen::Matrix3d> rotations;
  for (image_t i = 1; i <= 8; ++i) rotations[i] = true_R_[i] * frame;
  std::vector<double> turns = JoinTurnsDeg(plan, model_, parts, rotations);
  ASSERT_EQ(turns.size(), 2u);
  EXPECT_EQ(turns[0], 0);
  EXPECT_LT(turns[1], 1e-6);
  // Part B turned by 12 deg against A (as false pairs elsewhere turn it).
  const Eigen::Matrix3d turn =
      AngleAxisToRotation(Eigen::Vector3d(0, 0, DegToRad(12)));
  for (image_t i = 5; i <= 8; ++i) rotations[i] = true_R_[i] * turn * frame;
  turns = JoinTurnsDeg(plan, model_, parts, rotations);
  EXPECT_NEAR(turns[1], 12, 1e-6);
  // Kept, the join leaves one group of 8 images; turned by 12 deg (over
  // 10), two of 4.
  EXPECT_EQ(NumLargeGroupsKept(plan, {0, 3}, 10, 4), 1);
  EXPECT_EQ(NumLargeGroupsKept(plan, turns, 10, 4), 2);
  EXPECT_EQ(NumLargeGroupsKept(plan, turns, 10, 5), 0);
  EXPECT_EQ(NumLargeGroupsKept(plan, turns, 15, 5), 1);
  // Part B left out of the new rotations: the join is lost.
  for (image_t i = 5; i <= 8; ++i) rotations.erase(i);
  turns = JoinTurnsDeg(plan, model_, parts, rotations);
  EXPECT_EQ(turns[1], 180);
  // Parts not joined are not measured.
  const PartMergePlan alone = PlanPartMerge(PartMergeOptions(), model_, parts,
                                            {pairs_[2]}, {geometries_[2]});
  ASSERT_EQ(alone.num_groups, 2);
  turns = JoinTurnsDeg(alone, model_, parts, rotations);
  EXPECT_EQ(turns[1], 0);
}

TEST_F(PartMergeTest, NothingJoinedThroughAFalsePairAlone) {
  const PartMergePlan plan =
      PlanPartMerge(PartMergeOptions(), model_, {{1, 2, 3, 4}, {5, 6, 7, 8}},
                    {pairs_[2]}, {geometries_[2]});
  EXPECT_EQ(plan.num_pairs_across, 1);
  EXPECT_EQ(plan.num_confirmed, 0);
  EXPECT_EQ(plan.num_groups, 2);
  EXPECT_TRUE(plan.contradicted.empty());
  // Not joined, but refuted by A's points all the same: 20 points to test,
  // fewer than 5 met.
  EXPECT_EQ(plan.refuted, (std::set<std::pair<image_t, image_t>>{{2, 6}}));
}

TEST_F(PartMergeTest, TooFewPointsToTestRefuteNothing) {
  // The false pair with 4 matches only: too few points to test.
  TwoViewGeometry geometry = geometries_[2];
  geometry.inlier_matches.resize(4);
  const PartMergePlan plan =
      PlanPartMerge(PartMergeOptions(), model_, {{1, 2, 3, 4}, {5, 6, 7, 8}},
                    {pairs_[2]}, {geometry});
  EXPECT_TRUE(plan.refuted.empty());
}

TEST_F(PartMergeTest, ARotationOffByMoreThanTheRayErrorIsNotConfirmed) {
  // The true matches of (1, 5) with the pair's rotation 1 deg off: b's rays
  // no longer meet A's points from one centre within 0.1 deg.
  const Eigen::Matrix3d off =
      AngleAxisToRotation(Eigen::Vector3d(0, 0, DegToRad(1))) * pairs_[0].R;
  EXPECT_FALSE(CheckPair(0, &off).confirmed);
}

// The plan's pairs kept for the re-mapping (contradicted and refuted ones
// removed).
std::vector<ImagePairGeometry> Kept(
    const PartMergePlan& plan, const std::vector<ImagePairGeometry>& pairs) {
  std::vector<ImagePairGeometry> kept;
  for (const ImagePairGeometry& pair : pairs) {
    const auto key = std::minmax(pair.image_id1, pair.image_id2);
    if (!plan.contradicted.count(key) && !plan.refuted.count(key)) {
      kept.push_back(pair);
    }
  }
  return kept;
}

TEST_F(PartMergeTest, JoinAtTwoImagesOnEachSideMakesTheModelRigid) {
  const std::vector<std::vector<image_t>> parts = {{1, 2, 3, 4}, {5, 6, 7, 8}};
  // The parts share no point: two rigid parts of 4 images.
  EXPECT_EQ(
      AnalyzeModelRigidity(ModelRigidityOptions(), model_, 4).num_large_blocks,
      2);
  const PartMergePlan plan =
      PlanPartMerge(PartMergeOptions(), model_, parts, pairs_, geometries_);
  // (1, 5) and (3, 7): images 5 and 7 each see 20 points of A (seen by all
  // of 1-4), so 5 and 7 are tied to A apart from each other: one piece.
  const ModelRigidity joined =
      JoinedRigidity(model_, parts, Kept(plan, pairs_), geometries_,
                     /*min_model_size=*/4);
  EXPECT_EQ(joined.num_large_blocks, 1);
  ASSERT_EQ(joined.blocks.size(), 1u);
  EXPECT_EQ(joined.blocks[0].size(), 8u);
  // Without the join's pairs the parts stay apart: the false pair (2, 6),
  // kept, ties A to image 6 alone (its random keypoints observe no point of
  // B), an articulation.
  EXPECT_EQ(JoinedRigidity(model_, parts, {pairs_[2]}, geometries_, 4)
                .num_large_blocks,
            2);
}

TEST_F(PartMergeTest, ArticulationJoinTiesNothing) {
  // Only (1, 5) confirmed: every tie across goes through image 5, whose
  // relative scale the points do not fix. The re-mapped model would be
  // split at 5 again: the step must not map again for it.
  const std::vector<std::vector<image_t>> parts = {{1, 2, 3, 4}, {5, 6, 7, 8}};
  const std::vector<ImagePairGeometry> pairs = {pairs_[0], pairs_[2]};
  // One pair suffices to join here (by default two must agree).
  PartMergeOptions options;
  options.min_join_pairs = 1;
  const PartMergePlan plan =
      PlanPartMerge(options, model_, parts, pairs, geometries_);
  ASSERT_EQ(plan.num_confirmed, 1);
  ASSERT_EQ(plan.num_groups, 1);
  const ModelRigidity joined =
      JoinedRigidity(model_, parts, Kept(plan, pairs), geometries_, 4);
  EXPECT_EQ(joined.num_large_blocks, 2);
  ASSERT_EQ(joined.blocks.size(), 2u);
  EXPECT_EQ(joined.blocks[0], (std::vector<image_t>{1, 2, 3, 4}));
  EXPECT_EQ(joined.blocks[1], (std::vector<image_t>{5, 6, 7, 8}));
}

TEST_F(PartMergeTest, JoinThroughPointsOfBothPartsIsRigid) {
  // (1, 5) only, but image 5's keypoints of A's points also observe points
  // of B seen by image 6: the pair's matches join each into one point seen
  // from A and from 5 and 6, which ties 6 to A too (the scale about 5 is
  // fixed).
  for (const FeatureMatch& match : geometries_[0].inlier_matches) {
    const point2D_t idx_6 =
        static_cast<point2D_t>(model_.images.at(6).points2D.size());
    model_.images.at(6).points2D.emplace_back();
    AddPoint3D(Eigen::Vector3d(0, 0, 10), {{5, match.point2D_idx2}, {6, idx_6}},
               &model_);
  }
  const std::vector<std::vector<image_t>> parts = {{1, 2, 3, 4}, {5, 6, 7, 8}};
  const std::vector<ImagePairGeometry> pairs = {pairs_[0], pairs_[2]};
  const PartMergePlan plan =
      PlanPartMerge(PartMergeOptions(), model_, parts, pairs, geometries_);
  ASSERT_EQ(plan.num_confirmed, 1);
  const ModelRigidity joined =
      JoinedRigidity(model_, parts, Kept(plan, pairs), geometries_, 4);
  EXPECT_EQ(joined.num_large_blocks, 1);
  ASSERT_EQ(joined.blocks.size(), 1u);
  EXPECT_EQ(joined.blocks[0].size(), 8u);
  // The model itself is untouched (still two parts).
  EXPECT_EQ(
      AnalyzeModelRigidity(ModelRigidityOptions(), model_, 4).num_large_blocks,
      2);
}

TEST_F(PartMergeTest, OneConfirmedPairAloneJoinsNothing) {
  const std::vector<std::vector<image_t>> parts = {{1, 2, 3, 4}, {5, 6, 7, 8}};
  const PartMergePlan plan = PlanPartMerge(PartMergeOptions(), model_, parts,
                                           {pairs_[0], pairs_[2]}, geometries_);
  EXPECT_EQ(plan.num_confirmed, 1);
  ASSERT_EQ(plan.joins.size(), 1u);
  EXPECT_EQ(plan.joins[0].num_pairs, 1);
  EXPECT_EQ(plan.joins[0].num_agreeing, 1);
  EXPECT_FALSE(plan.joins[0].agreed);
  EXPECT_EQ(plan.num_groups, 2);
  EXPECT_TRUE(plan.contradicted.empty());
}

TEST_F(PartMergeTest, GhostPosePairIsConfirmedButJoinsOnlyWithAgreement) {
  // (4, 8) fits a ghost pose of 8: turned by 30 deg, elsewhere.
  AddGhostPair(4, 8, 0,
               AngleAxisToRotation(Eigen::Vector3d(0, DegToRad(30), 0)),
               Eigen::Vector3d(3, -1, 1));
  const std::vector<std::vector<image_t>> parts = {{1, 2, 3, 4}, {5, 6, 7, 8}};
  // The ray test alone cannot tell it from a true pair.
  const CrossPairCheck ghost =
      CheckCrossPair(PartMergeOptions(), model_, {1, 2, 3, 4}, 4, 8,
                     pairs_[3].R, Matches(geometries_[3]));
  EXPECT_TRUE(ghost.confirmed);
  EXPECT_EQ(ghost.num_met, 20);
  // With one true pair: two confirmed pairs that disagree by 30 deg.
  const PartMergePlan two = PlanPartMerge(PartMergeOptions(), model_, parts,
                                          {pairs_[0], pairs_[3]}, geometries_);
  EXPECT_EQ(two.num_confirmed, 2);
  ASSERT_EQ(two.joins.size(), 1u);
  EXPECT_EQ(two.joins[0].num_pairs, 2);
  EXPECT_EQ(two.joins[0].num_agreeing, 1);
  EXPECT_EQ(two.num_groups, 2);
  // Rotations agreeing within 31 deg: the ghost's centre still refutes the
  // join's similarity.
  PartMergeOptions wide;
  wide.max_join_spread_deg = 31;
  const auto num_agreeing = [&](const PartMergeOptions& options,
                                const std::vector<ImagePairGeometry>& pairs) {
    return PlanPartMerge(options, model_, parts, pairs, geometries_)
        .joins[0]
        .num_agreeing;
  };
  EXPECT_EQ(num_agreeing(wide, {pairs_[0], pairs_[3]}), 1);
  // A ghost pose with the true rotation (turn 0) elsewhere: the rotations
  // agree, the centres do not.
  AddGhostPair(4, 8, 20, Eigen::Matrix3d::Identity(),
               Eigen::Vector3d(3, -1, 1));
  const CrossPairCheck unturned =
      CheckCrossPair(PartMergeOptions(), model_, {1, 2, 3, 4}, 4, 8,
                     pairs_[4].R, Matches(geometries_[4]));
  EXPECT_TRUE(unturned.confirmed);
  EXPECT_EQ(num_agreeing(PartMergeOptions(), {pairs_[0], pairs_[4]}), 1);
  pairs_.pop_back();
  geometries_.pop_back();
  // With both true pairs: they agree, the parts are joined through them
  // (the truth's rotations) and the ghost pair contradicts the join.
  const PartMergePlan three =
      PlanPartMerge(PartMergeOptions(), model_, parts, pairs_, geometries_);
  EXPECT_EQ(three.num_confirmed, 3);
  ASSERT_EQ(three.joins.size(), 1u);
  EXPECT_EQ(three.joins[0].num_pairs, 3);
  EXPECT_EQ(three.joins[0].num_agreeing, 2);
  EXPECT_TRUE(three.joins[0].agreed);
  EXPECT_EQ(three.joins[0].num_points, 40);
  EXPECT_EQ(three.num_groups, 1);
  for (image_t i = 5; i <= 8; ++i) {
    const Eigen::Matrix3d R =
        model_.images.at(i).cam_from_world.rotation.toRotationMatrix() *
        three.correction[1];
    EXPECT_LT(AngularDistanceDeg(R, true_R_[i]), 1e-6) << i;
  }
  EXPECT_EQ(three.contradicted,
            (std::set<std::pair<image_t, image_t>>{{2, 6}, {4, 8}}));
}

TEST(PartMergeOptions, Check) {
  PartMergeOptions options;
  EXPECT_NO_THROW(options.Check());
  options.min_met_points = 1;
  EXPECT_ANY_THROW(options.Check());
  options = PartMergeOptions();
  options.max_join_turn_deg = 0;
  EXPECT_ANY_THROW(options.Check());
  options = PartMergeOptions();
  options.max_rounds = 0;
  EXPECT_ANY_THROW(options.Check());
  options = PartMergeOptions();
  EXPECT_TRUE(options.check_rigid_joins);
  options = PartMergeOptions();
  options.min_image_fraction = 1.5;
  EXPECT_ANY_THROW(options.Check());
  // The join's agreement: errors name the flag.
  const auto error_of = [](const PartMergeOptions& bad) -> std::string {
    try {
      bad.Check();
    } catch (const std::exception& error) {
      return error.what();
    }
    return "";
  };
  options = PartMergeOptions();
  options.min_join_pairs = 0;
  EXPECT_NE(error_of(options).find("--PartMerge.min_join_pairs"),
            std::string::npos);
  options = PartMergeOptions();
  options.max_join_spread_deg = 0;
  EXPECT_NE(error_of(options).find("--PartMerge.max_join_spread_deg"),
            std::string::npos);
  options = PartMergeOptions();
  options.max_join_center_error = 0;
  EXPECT_NE(error_of(options).find("--PartMerge.max_join_center_error"),
            std::string::npos);
}

}  // namespace
}  // namespace colmap_irav4
