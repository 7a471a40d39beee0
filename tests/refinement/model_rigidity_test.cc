#include "colmap_irav4/refinement/model_rigidity.h"

#include <gtest/gtest.h>

#include "colmap_irav4/scene/reconstruction_utils.h"

namespace colmap_irav4 {
namespace {

// Images 1..num_images with 1,000 free keypoints each.
Reconstruction MakeImages(int num_images) {
  Reconstruction reconstruction;
  reconstruction.cameras[1].camera_id = 1;
  for (int i = 1; i <= num_images; ++i) {
    Image& image = reconstruction.images[i];
    image.image_id = i;
    image.camera_id = 1;
    image.points2D.resize(1000);
  }
  return reconstruction;
}

// `count` points, each seen by all of `image_ids` (at their next free
// keypoints).
void AddPoints(const std::vector<image_t>& image_ids, int count,
               Reconstruction* reconstruction) {
  for (int k = 0; k < count; ++k) {
    std::vector<TrackElement> track;
    for (const image_t image_id : image_ids) {
      const Image& image = reconstruction->images.at(image_id);
      point2D_t idx = 0;
      while (image.points2D[idx].point3D_id != kInvalidPoint3DId) ++idx;
      track.push_back({image_id, idx});
    }
    AddPoint3D(Eigen::Vector3d::Zero(), track, reconstruction);
  }
}

std::vector<image_t> Sorted(std::vector<image_t> ids) {
  std::sort(ids.begin(), ids.end());
  return ids;
}

TEST(ModelRigidity, OneRigidPiece) {
  Reconstruction reconstruction = MakeImages(6);
  AddPoints({1, 2, 3, 4}, 20, &reconstruction);
  AddPoints({3, 4, 5, 6}, 20, &reconstruction);
  const ModelRigidity rigidity =
      AnalyzeModelRigidity(ModelRigidityOptions(), reconstruction, 3);
  ASSERT_EQ(rigidity.blocks.size(), 1u);
  EXPECT_EQ(rigidity.num_large_blocks, 1);
  EXPECT_EQ(rigidity.blocks[0].size(), 6u);
}

TEST(ModelRigidity, PartsJoinedThroughOneImageAreSeparateBlocks) {
  // 1-4 and 4-7 share image 4 only: the scale of one part about image 4's
  // centre is free.
  Reconstruction reconstruction = MakeImages(7);
  AddPoints({1, 2, 3, 4}, 20, &reconstruction);
  AddPoints({4, 5, 6, 7}, 25, &reconstruction);
  // A few points across do not tie the parts (fewer than 15).
  AddPoints({3, 5}, 10, &reconstruction);
  ModelRigidity rigidity =
      AnalyzeModelRigidity(ModelRigidityOptions(), reconstruction, 3);
  ASSERT_EQ(rigidity.blocks.size(), 2u);
  EXPECT_EQ(rigidity.num_large_blocks, 2);
  // Image 4 stays with the part it shares the most points with (75 with
  // 5-7, 60 with 1-3).
  EXPECT_EQ(Sorted(rigidity.blocks[0]), std::vector<image_t>({4, 5, 6, 7}));
  EXPECT_EQ(Sorted(rigidity.blocks[1]), std::vector<image_t>({1, 2, 3}));

  // Enough points across make it one piece.
  AddPoints({3, 5}, 5, &reconstruction);
  rigidity = AnalyzeModelRigidity(ModelRigidityOptions(), reconstruction, 3);
  EXPECT_EQ(rigidity.num_large_blocks, 1);
  EXPECT_EQ(rigidity.blocks[0].size(), 7u);
}

TEST(ModelRigidity, PartsTiedByPointsOverSeveralImagePairsAreOneRigidPiece) {
  // 1-4 and 4-7 share image 4, and no image pair across shares 15 points:
  // ties are counted per point seen from both parts (not through image 4),
  // over all image pairs.
  Reconstruction reconstruction = MakeImages(7);
  AddPoints({1, 2, 3, 4}, 20, &reconstruction);
  AddPoints({4, 5, 6, 7}, 25, &reconstruction);
  AddPoints({3, 5}, 6, &reconstruction);
  AddPoints({2, 6}, 5, &reconstruction);
  AddPoints({1, 2, 6, 7}, 3, &reconstruction);  // one tie each
  // Seen from one part and the shared image only: no tie.
  AddPoints({3, 4}, 10, &reconstruction);
  AddPoints({4, 5, 6}, 10, &reconstruction);
  ModelRigidity rigidity =
      AnalyzeModelRigidity(ModelRigidityOptions(), reconstruction, 3);
  ASSERT_EQ(rigidity.blocks.size(), 2u);  // 14 points across
  EXPECT_EQ(rigidity.num_large_blocks, 2);

  AddPoints({3, 4, 6}, 1, &reconstruction);  // the 15th
  rigidity = AnalyzeModelRigidity(ModelRigidityOptions(), reconstruction, 3);
  ASSERT_EQ(rigidity.blocks.size(), 1u);
  EXPECT_EQ(rigidity.num_large_blocks, 1);
  EXPECT_EQ(rigidity.blocks[0].size(), 7u);
  ASSERT_EQ(rigidity.joined_blocks.size(), 1u);
  EXPECT_EQ(rigidity.joined_blocks[0].size(), 7u);
}

TEST(ModelRigidity, TiesAcrossMergedPartsAddUp) {
  // A chain 1-3, 3-5, 5-7 of parts joined at images 3 and 5: the first two
  // are tied by 15 points across (over two image pairs); the third is tied
  // by 8 points to each of them, which makes it rigid with both once they
  // are one piece.
  Reconstruction reconstruction = MakeImages(7);
  AddPoints({1, 2, 3}, 20, &reconstruction);
  AddPoints({3, 4, 5}, 20, &reconstruction);
  AddPoints({5, 6, 7}, 20, &reconstruction);
  AddPoints({2, 4}, 8, &reconstruction);
  AddPoints({1, 4}, 7, &reconstruction);
  AddPoints({1, 6}, 8, &reconstruction);
  AddPoints({4, 7}, 8, &reconstruction);
  const ModelRigidity rigidity =
      AnalyzeModelRigidity(ModelRigidityOptions(), reconstruction, 3);
  ASSERT_EQ(rigidity.blocks.size(), 1u);
  EXPECT_EQ(rigidity.blocks[0].size(), 7u);
}

TEST(ModelRigidity, LongTracksAcrossPartsCountOnce) {
  // 14 points each seen by three images of either part: every pair across
  // shares 14 points, and the parts are tied by 14 points, not by one tie
  // per image pair.
  Reconstruction reconstruction = MakeImages(7);
  AddPoints({1, 2, 3, 4}, 20, &reconstruction);
  AddPoints({4, 5, 6, 7}, 25, &reconstruction);
  AddPoints({1, 2, 3, 5, 6, 7}, 14, &reconstruction);
  const ModelRigidity rigidity =
      AnalyzeModelRigidity(ModelRigidityOptions(), reconstruction, 3);
  EXPECT_EQ(rigidity.num_large_blocks, 2);
}

TEST(ModelRigidity, DisconnectedPartsAreSeparateBlocks) {
  Reconstruction reconstruction = MakeImages(6);
  AddPoints({1, 2, 3}, 20, &reconstruction);
  AddPoints({4, 5, 6}, 20, &reconstruction);
  const ModelRigidity rigidity =
      AnalyzeModelRigidity(ModelRigidityOptions(), reconstruction, 3);
  EXPECT_EQ(rigidity.num_large_blocks, 2);
}

TEST(ModelRigidity, SmallPendantPartsDoNotCount) {
  // Image 5 hangs on image 4 alone: a block of two images, below the
  // smallest model.
  Reconstruction reconstruction = MakeImages(5);
  AddPoints({1, 2, 3, 4}, 20, &reconstruction);
  AddPoints({4, 5}, 20, &reconstruction);
  const ModelRigidity rigidity =
      AnalyzeModelRigidity(ModelRigidityOptions(), reconstruction, 3);
  ASSERT_EQ(rigidity.blocks.size(), 2u);
  EXPECT_EQ(rigidity.num_large_blocks, 1);
  EXPECT_EQ(Sorted(rigidity.blocks[0]), std::vector<image_t>({1, 2, 3, 4}));
  EXPECT_EQ(Sorted(rigidity.blocks[1]), std::vector<image_t>({5}));
}

}  // namespace
}  // namespace colmap_irav4
