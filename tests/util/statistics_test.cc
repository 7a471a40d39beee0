#include "colmap_irav4/util/statistics.h"

#include <cmath>

#include <gtest/gtest.h>

namespace colmap_irav4 {
namespace {

TEST(Statistics, MedianMeanAndStandardDeviation) {
  EXPECT_EQ(Median({}), 0.0);
  EXPECT_EQ(Median({3, 1, 2}), 2.0);
  EXPECT_EQ(Median({4, 1, 3, 2}), 2.5);
  EXPECT_EQ(Mean({}), 0.0);
  EXPECT_DOUBLE_EQ(Mean({1, 2, 6}), 3.0);
  // Sample deviation (n - 1): of 1, 2, 6, sqrt((4 + 1 + 9) / 2).
  EXPECT_DOUBLE_EQ(StandardDeviation({1, 2, 6}), std::sqrt(7.0));
  EXPECT_EQ(StandardDeviation({5}), 0.0);
  EXPECT_EQ(StandardDeviation({}), 0.0);
}

}  // namespace
}  // namespace colmap_irav4
