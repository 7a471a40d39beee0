#include "colmap_irav4/util/ceres_solve.h"

#include <map>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace colmap_irav4 {
namespace {

TEST(ParameterBlockCopies, InAddressOrderAsAddedAndWrittenBack) {
  // Model blocks in map nodes allocated in reverse key order: the copies are
  // in the order they are added, whatever the nodes' addresses.
  std::map<int, std::vector<double>> model;
  for (int key = 4; key >= 0; --key) {
    model.emplace(key, std::vector<double>(1 + key % 3, key));
  }
  ParameterBlockCopies copies(1 + 2 + 3 + 1 + 2);
  std::vector<std::pair<int, double*>> blocks;
  for (auto& [key, values] : model) {
    blocks.emplace_back(key, copies.Add(values.data(), values.size()));
    EXPECT_EQ(*blocks.back().second, key);
  }
  for (size_t k = 1; k < blocks.size(); ++k) {
    EXPECT_EQ(blocks[k].second,
              blocks[k - 1].second + model.at(blocks[k - 1].first).size());
  }
  EXPECT_EQ(FindBlock(blocks, 3), blocks[3].second);

  // Solved copies reach the model only when written back.
  blocks[2].second[1] = -7.5;
  EXPECT_EQ(model.at(2)[1], 2.0);
  copies.CopyToModel();
  EXPECT_EQ(model.at(2), (std::vector<double>{2.0, -7.5, 2.0}));
  EXPECT_EQ(model.at(4), (std::vector<double>{4.0, 4.0}));
}

TEST(ParameterBlockCopiesDeathTest, NoRoomIsAProgrammingError) {
  double values[3] = {1, 2, 3};
  ParameterBlockCopies copies(4);
  copies.Add(values, 3);
  // Another block would move the copies Ceres holds.
  EXPECT_DEATH(copies.Add(values, 3), "would move");
  std::vector<std::pair<int, double*>> blocks = {{1, values}};
  EXPECT_DEATH(FindBlock(blocks, 2), "no block 2");
}

}  // namespace
}  // namespace colmap_irav4
