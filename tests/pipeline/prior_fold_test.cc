// The priors' judgement of a fold (pipeline/prior_fold.h) on a hand-made
// model: 20 cameras on a circle of 20 m, each with a position prior of
// 1 m standard deviation a fixed half metre or so off, and a "turned"
// group of 8 consecutive cameras moved 10 m (10 standard deviations).

#include <algorithm>
#include <cmath>
#include <map>
#include <vector>

#include <gtest/gtest.h>

#include "colmap_irav4/geometry/rotation.h"
#include "colmap_irav4/pipeline/component_mapper.h"
#include "colmap_irav4/pipeline/prior_fold.h"

namespace colmap_irav4 {
namespace {

constexpr int kNumImages = 20;

Eigen::Vector3d TrueCenter(image_t image_id) {
  const double angle = 2 * M_PI * image_id / kNumImages;
  return Eigen::Vector3d(20 * std::cos(angle), 20 * std::sin(angle), 0);
}

bool Turned(image_t image_id) { return image_id >= 1 && image_id <= 8; }

// The model: the true centres, those of the turned group 10 m off when
// `folded`; identity rotations.
Reconstruction Model(bool folded) {
  Reconstruction model;
  for (image_t image_id = 1; image_id <= kNumImages; ++image_id) {
    Image& image = model.images[image_id];
    image.image_id = image_id;
    Eigen::Vector3d center = TrueCenter(image_id);
    if (folded && Turned(image_id)) center += Eigen::Vector3d(10, 0, 0);
    image.cam_from_world.translation = -center;
  }
  return model;
}

PosePriors Priors() {
  PosePriors priors;
  for (image_t image_id = 1; image_id <= kNumImages; ++image_id) {
    PosePrior& prior = priors[image_id];
    // A fixed offset of about half a standard deviation, different per image.
    prior.position =
        TrueCenter(image_id) + 0.5 * Eigen::Vector3d(std::sin(3.0 * image_id),
                                                     std::cos(5.0 * image_id),
                                                     std::sin(7.0 * image_id));
    prior.position_covariance = Eigen::Matrix3d::Identity();
  }
  return priors;
}

// Each camera paired with its next three around the circle.
std::vector<ImagePairGeometry> NeighbourPairs() {
  std::vector<ImagePairGeometry> pairs;
  for (image_t a = 1; a <= kNumImages; ++a) {
    for (image_t step = 1; step <= 3; ++step) {
      ImagePairGeometry pair;
      pair.image_id1 = a;
      pair.image_id2 = (a + step - 1) % kNumImages + 1;
      pairs.push_back(pair);
    }
  }
  return pairs;
}

std::vector<image_t> TurnedGroup() { return {1, 2, 3, 4, 5, 6, 7, 8}; }

TEST(PriorFold, AgreementCountsAndCapsTheResiduals) {
  const PosePriors priors = Priors();
  const PriorAgreement right =
      MeasurePriorAgreement(Model(false), priors, PosePriorOptions());
  EXPECT_EQ(right.num_priors, kNumImages);
  EXPECT_EQ(right.num_within, kNumImages);
  EXPECT_LT(right.capped_cost, kNumImages * 0.75);  // each r < 0.87
  const PriorAgreement folded =
      MeasurePriorAgreement(Model(true), priors, PosePriorOptions());
  EXPECT_EQ(folded.num_within, kNumImages - 8);
  // 8 capped at 9 each, the rest as in the correct model.
  double expected = 8 * 9.0;
  for (image_t image_id = 9; image_id <= kNumImages; ++image_id) {
    expected += std::pow(right.residuals.at(image_id), 2);
  }
  EXPECT_NEAR(folded.capped_cost, expected, 1e-9);
  EXPECT_TRUE(PriorsAgreeBetter(folded, right));
  EXPECT_FALSE(PriorsAgreeBetter(right, folded));
  EXPECT_FALSE(PriorsAgreeBetter(right, right));
  // An image lost is never better.
  Reconstruction smaller = Model(false);
  smaller.images.erase(20);
  EXPECT_FALSE(PriorsAgreeBetter(
      folded, MeasurePriorAgreement(smaller, priors, PosePriorOptions())));
}

TEST(PriorFold, OutlierGroupsOnlyWhenConnectedAndLarge) {
  const PosePriors priors = Priors();
  const PriorAgreement folded =
      MeasurePriorAgreement(Model(true), priors, PosePriorOptions());
  EXPECT_EQ(PriorOutlierGroups(folded, NeighbourPairs(), 3), TurnedGroup());
  // More than the group holds: none.
  EXPECT_TRUE(PriorOutlierGroups(folded, NeighbourPairs(), 9).empty());
  // The same outliers with no pair between them: scattered GPS outliers.
  std::vector<ImagePairGeometry> apart;
  for (const ImagePairGeometry& pair : NeighbourPairs()) {
    if (!(Turned(pair.image_id1) && Turned(pair.image_id2))) {
      apart.push_back(pair);
    }
  }
  EXPECT_TRUE(PriorOutlierGroups(folded, apart, 3).empty());
  const PriorAgreement right =
      MeasurePriorAgreement(Model(false), priors, PosePriorOptions());
  EXPECT_TRUE(PriorOutlierGroups(right, NeighbourPairs(), 3).empty());
}

TEST(PriorFold, PairContrastAcrossAFold) {
  const PosePriors priors = Priors();
  const std::vector<ImagePairGeometry> pairs = NeighbourPairs();
  // Across the turned group's cut the pairs are 10 std off, within it the
  // priors' own offsets: far above the threshold.
  const double folded = PriorPairContrast(
      Model(true), priors, PosePriorOptions(), pairs, TurnedGroup());
  EXPECT_GT(folded, 5 * kMinPriorPairContrast);
  // The same cut of the correct model: no contrast worth a second mapping.
  const double right = PriorPairContrast(
      Model(false), priors, PosePriorOptions(), pairs, TurnedGroup());
  EXPECT_GT(right, 0);
  EXPECT_LT(right, kMinPriorPairContrast);
  // Too few pairs across (a cut of one image has 6): no figure.
  EXPECT_EQ(PriorPairContrast(Model(true), priors, PosePriorOptions(),
                              {pairs[0], pairs[1]}, TurnedGroup()),
            0);
}

TEST(PriorFold, PairsReorientedAcrossACut) {
  // Images 1-2 turned 180 deg about z in the model; measured rotations: a
  // true pair (1, 2) within the side, a true pair (2, 3) across it (the
  // model contradicts it), a false pair (1, 3) across it (the model agrees),
  // a false pair (1, 4)... within the side none; (3, 4) true, right side.
  Reconstruction model;
  const Eigen::Quaterniond turn(
      Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()));
  for (image_t id = 1; id <= 4; ++id) {
    model.images[id].image_id = id;
    if (id <= 2) model.images[id].cam_from_world.rotation = turn;
  }
  auto pair = [](image_t a, image_t b, const Eigen::Matrix3d& R) {
    ImagePairGeometry p;
    p.image_id1 = a;
    p.image_id2 = b;
    p.R = R;
    return p;
  };
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d T = turn.toRotationMatrix();
  // R_12 = R2 R1^T: the truth has every rotation the identity.
  const std::vector<ImagePairGeometry> pairs = {
      pair(1, 2, I),  // true, within: the model agrees
      pair(2, 3, I),  // true, across: the model contradicts (it says T^T)
      pair(1, 3, T.transpose()),  // false, across: the model agrees
      pair(3, 4, I),              // true, within the rest
      pair(1, 2, T)};             // false, within: the model contradicts
  const std::vector<image_t> side = {1, 2};
  std::vector<ImagePairGeometry> kept =
      PairsReorientedAcrossCut(pairs, model, side, 5.0);
  // The fold resolution's: across, only the contradicted pairs stay.
  ASSERT_EQ(kept.size(), 4u);
  EXPECT_EQ(kept[1].image_id2, 3u);
  EXPECT_EQ(kept[1].image_id1, 2u);
  kept = PairsReorientedAcrossCut(pairs, model, side, 5.0,
                                  /*drop_contradicted_within=*/true);
  // ... and with the side turned back, the pairs within it that the model
  // contradicts go too: the four true pairs minus none, the false ones out.
  ASSERT_EQ(kept.size(), 3u);
  for (const ImagePairGeometry& p : kept) EXPECT_TRUE(p.R.isApprox(I));
}

TEST(PriorFold, SettledOutcomeCountsRemovedAndRestoredPairsApart) {
  EXPECT_EQ(PriorSettledOutcome(26, 640),
            "resolved by pose priors (26 images turned back, 640 pairs "
            "removed)");
  // Tower 60, seed 1 (docs/notes/2026-12-04-priors-table.md): the camera
  // left turned alone gets back more pairs (22) than it loses (18); their
  // difference as an unsigned count was written as 18446744073709551612.
  EXPECT_EQ(PriorSettledOutcome(28, 651, 18, 22),
            "resolved by pose priors (28 images turned back, 651 pairs "
            "removed), cameras turned alone re-oriented (18 pairs at them "
            "removed, 22 restored)");
}

// A ring of 12 cameras 20 m around the origin, looking at it: camera k's
// mirrored twin (the pose turned 180 deg about the vertical) is camera k + 6.
Rigid3d RingPose(int k) {
  const double angle = 2 * M_PI * ((k - 1) % 12) / 12;
  const Eigen::Vector3d center(20 * std::cos(angle), 20 * std::sin(angle), 0);
  const Eigen::Vector3d z = -center.normalized();
  const Eigen::Vector3d y = -Eigen::Vector3d::UnitZ();
  Eigen::Matrix3d R;
  R.row(0) = y.cross(z).transpose();
  R.row(1) = y.transpose();
  R.row(2) = z.transpose();
  Rigid3d pose;
  pose.rotation = Eigen::Quaterniond(R);
  pose.translation = -(R * center);
  return pose;
}

// The relative pose of (a, b) measured from the poses the images were
// matched at: cam_b_from_cam_a, unit translation.
ImagePairGeometry RingPair(image_t a, image_t b, const Rigid3d& pose_a,
                           const Rigid3d& pose_b) {
  ImagePairGeometry pair;
  pair.image_id1 = a;
  pair.image_id2 = b;
  const Eigen::Matrix3d Ra = pose_a.rotation.toRotationMatrix();
  const Eigen::Matrix3d Rb = pose_b.rotation.toRotationMatrix();
  pair.R = Rb * Ra.transpose();
  pair.t = (pose_b.translation - pair.R * pose_a.translation).normalized();
  return pair;
}

// Camera 1's pairs: true ones with its neighbours 2, 3, 11, 12 and mirror
// ones (its matches made at its twin's place, camera 7's) with 5, 6, 8, 9;
// camera 1 first in some pairs, second in others.
std::vector<ImagePairGeometry> RingPairsOfCameraOne() {
  std::vector<ImagePairGeometry> pairs;
  for (const image_t other : {2, 3}) {
    pairs.push_back(RingPair(1, other, RingPose(1), RingPose(other)));
  }
  for (const image_t other : {11, 12}) {
    pairs.push_back(RingPair(other, 1, RingPose(other), RingPose(1)));
  }
  for (const image_t other : {8, 9}) {
    pairs.push_back(RingPair(1, other, RingPose(7), RingPose(other)));
  }
  for (const image_t other : {5, 6}) {
    pairs.push_back(RingPair(other, 1, RingPose(other), RingPose(7)));
  }
  return pairs;
}

// The ring's model, camera 1 at its twin's place (turned alone) or not.
Reconstruction RingModel(bool turned) {
  Reconstruction model;
  for (image_t id = 1; id <= 12; ++id) {
    model.images[id].image_id = id;
    model.images[id].cam_from_world = RingPose(turned && id == 1 ? 7 : id);
  }
  return model;
}

TEST(PriorFold, CameraTurnedAloneTurnedBackAcrossItsOwnPairs) {
  // Camera 1 turned alone: its mirror pairs agree with the model, its four
  // true pairs contradict it and give back its true pose.
  const TurnedBackPose turned =
      TurnBackAlone(RingModel(true), RingPairsOfCameraOne(), 1, 5.0);
  ASSERT_TRUE(turned.found);
  EXPECT_LT(
      AngularDistanceDeg(turned.cam_from_world.rotation.toRotationMatrix(),
                         RingPose(1).rotation.toRotationMatrix()),
      1e-6);
  EXPECT_LT((turned.cam_from_world.Inverse().translation -
             RingPose(1).Inverse().translation)
                .norm(),
            1e-6);
  ASSERT_EQ(turned.pairs.size(), 4u);
  for (const ImagePairGeometry& pair : turned.pairs) {
    const image_t other = pair.image_id1 == 1 ? pair.image_id2 : pair.image_id1;
    EXPECT_TRUE(other == 2 || other == 3 || other == 11 || other == 12);
  }
  // With only two of the true pairs left, no pose: too few to check one.
  std::vector<ImagePairGeometry> two = RingPairsOfCameraOne();
  two.erase(two.begin() + 1, two.begin() + 3);
  EXPECT_FALSE(TurnBackAlone(RingModel(true), two, 1, 5.0).found);
}

// Camera 1's ring pairs with `true_inliers` on each true pair and
// `mirror_inliers` on each mirror one.
std::vector<ImagePairGeometry> RingPairsWithInliers(int true_inliers,
                                                    int mirror_inliers) {
  std::vector<ImagePairGeometry> pairs = RingPairsOfCameraOne();
  for (size_t i = 0; i < pairs.size(); ++i) {
    pairs[i].num_inliers = i < 4 ? true_inliers : mirror_inliers;
  }
  return pairs;
}

TEST(PriorFold, TurnedAloneOnlyWhenItsOwnPairsSaySo) {
  // Turned alone: its true pairs (against the model) agree on its true pose
  // and outweigh its mirror ones.
  EXPECT_TRUE(TurnedAloneByItsPairs(RingModel(true),
                                    RingPairsWithInliers(100, 30), 1, 5.0));
  // The right way round, a few weak mirror pairs against it: they agree on
  // its twin's pose (TurnBackAlone finds it), but carry too few inliers.
  const Reconstruction right = RingModel(false);
  ASSERT_TRUE(
      TurnBackAlone(right, RingPairsWithInliers(100, 30), 1, 5.0).found);
  EXPECT_FALSE(
      TurnedAloneByItsPairs(right, RingPairsWithInliers(100, 30), 1, 5.0));
  // ... and with its pairs against it disagreeing with each other (random
  // false pairs: each a pose of its own), no other pose at all.
  std::vector<ImagePairGeometry> scattered = RingPairsWithInliers(100, 100);
  for (size_t i = 4; i < scattered.size(); ++i) {
    scattered[i].R = Eigen::AngleAxisd(0.3 * static_cast<double>(i),
                                       Eigen::Vector3d::UnitX())
                         .toRotationMatrix() *
                     scattered[i].R;
  }
  EXPECT_FALSE(TurnedAloneByItsPairs(right, scattered, 1, 5.0));
  // Half the inliers is the line: mirror pairs as strong as the true ones
  // make either pose as likely, and the camera stays a candidate.
  EXPECT_TRUE(
      TurnedAloneByItsPairs(right, RingPairsWithInliers(100, 50), 1, 5.0));
  EXPECT_FALSE(
      TurnedAloneByItsPairs(right, RingPairsWithInliers(100, 49), 1, 5.0));
}

TEST(PriorFold, GpsOutlierTurnedBackMovesToItsTwinNotToItsFix) {
  // Camera 1 right, its GPS fix 40 m off (3 m std): turned back across the
  // pairs the model contradicts (the mirror ones), it goes to its twin's
  // place, still tens of std from the fix; the mapper keeps it.
  const TurnedBackPose turned =
      TurnBackAlone(RingModel(false), RingPairsOfCameraOne(), 1, 5.0);
  ASSERT_TRUE(turned.found);
  EXPECT_LT((turned.cam_from_world.Inverse().translation -
             RingPose(7).Inverse().translation)
                .norm(),
            1e-6);
  PosePrior prior;
  prior.position =
      RingPose(1).Inverse().translation + Eigen::Vector3d(0, 40, 0);
  prior.position_covariance = 9 * Eigen::Matrix3d::Identity();
  const double r =
      (PositionPriorSqrtInformation(prior, PosePriorOptions()) *
       (turned.cam_from_world.Inverse().translation - prior.position))
          .norm();
  EXPECT_GT(r, PosePriorOptions().gate_std);
}

TEST(PriorFold,
     LoneTurnSettledOnlyWhenTheCameraMeetsItsPriorAndNoOtherIsWorse) {
  auto agreement = [](const std::map<image_t, double>& residuals) {
    PriorAgreement result;
    for (const auto& [image_id, r] : residuals) {
      result.residuals[image_id] = r;
      ++result.num_priors;
      result.num_within += r < 3.0;
      result.capped_cost += std::min(r * r, 9.0);
    }
    return result;
  };
  // Tower 60, seed 2 (docs/notes/2026-12-04-lone-turned-camera.md):
  // image35 from 25.9 std off its prior to 3.25.
  const PriorAgreement before = agreement({{35, 25.9}, {2, 1.0}, {3, 2.0}});
  EXPECT_TRUE(LoneTurnSettled(
      before, agreement({{35, 3.25}, {2, 1.1}, {3, 1.9}}), {35}, 6.0));
  // Not within the bound.
  EXPECT_FALSE(LoneTurnSettled(
      before, agreement({{35, 3.25}, {2, 1.1}, {3, 1.9}}), {35}, 3.0));
  // Another prior pushed beyond 3 std.
  EXPECT_FALSE(LoneTurnSettled(
      before, agreement({{35, 1.0}, {2, 1.1}, {3, 3.5}}), {35}, 6.0));
  // The others' capped cost up by more than 10%.
  EXPECT_FALSE(LoneTurnSettled(
      before, agreement({{35, 1.0}, {2, 1.5}, {3, 2.2}}), {35}, 6.0));
  // A right camera's noisy fix (courtyard 100, seed 3): within the gate
  // either way, not half as far.
  EXPECT_FALSE(LoneTurnSettled(agreement({{21, 4.9}, {2, 1.0}, {3, 2.0}}),
                               agreement({{21, 5.4}, {2, 1.0}, {3, 2.0}}), {21},
                               6.0));
  EXPECT_FALSE(LoneTurnSettled(agreement({{21, 9.0}, {2, 1.0}, {3, 2.0}}),
                               agreement({{21, 5.0}, {2, 1.0}, {3, 2.0}}), {21},
                               6.0));
  // The camera lost.
  EXPECT_FALSE(
      LoneTurnSettled(before, agreement({{2, 1.0}, {3, 2.0}}), {35}, 6.0));
}

TEST(PriorFold, SettledOutcomeNamesCamerasTurnedBackByTheirPriors) {
  EXPECT_EQ(PriorSettledOutcome(29, 684, 25, 23, 1),
            "resolved by pose priors (29 images turned back, 684 pairs "
            "removed), cameras turned alone re-oriented (25 pairs at them "
            "removed, 23 restored), 1 cameras turned alone turned back to "
            "their priors");
}

}  // namespace
}  // namespace colmap_irav4
