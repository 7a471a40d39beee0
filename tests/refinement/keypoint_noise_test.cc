#include "colmap_irav4/refinement/keypoint_noise.h"

#include <gtest/gtest.h>

namespace colmap_irav4 {
namespace {

TEST(KeypointScaleNoise, BinsByScaleAndDefaultsToOne) {
  KeypointScaleNoise noise;
  EXPECT_TRUE(noise.Empty());
  EXPECT_EQ(noise.Factor(3.0f), 1.0);

  noise.edges = {2.0f, 4.0f};
  noise.factors = {0.5, 1.0, 2.0};
  EXPECT_FALSE(noise.Empty());
  EXPECT_EQ(noise.Bin(1.0f), 0u);
  EXPECT_EQ(noise.Bin(2.0f), 1u);  // on an edge: the bin above
  EXPECT_EQ(noise.Bin(3.9f), 1u);
  EXPECT_EQ(noise.Bin(4.0f), 2u);
  EXPECT_EQ(noise.Bin(100.0f), 2u);
  EXPECT_EQ(noise.Factor(1.0f), 0.5);
  EXPECT_EQ(noise.Factor(3.0f), 1.0);
  EXPECT_EQ(noise.Factor(12.0f), 2.0);
}

}  // namespace
}  // namespace colmap_irav4
