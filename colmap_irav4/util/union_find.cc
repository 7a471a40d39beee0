#include "colmap_irav4/util/union_find.h"

#include <algorithm>
#include <limits>
#include <numeric>

#include <glog/logging.h>

namespace colmap_irav4 {

UnionFind::UnionFind(size_t num_elements)
    : parent_(num_elements), size_(num_elements, 1) {
  CHECK_LT(num_elements, std::numeric_limits<uint32_t>::max());
  std::iota(parent_.begin(), parent_.end(), uint32_t{0});
}

size_t UnionFind::Add() {
  CHECK_LT(parent_.size(), std::numeric_limits<uint32_t>::max());
  parent_.push_back(static_cast<uint32_t>(parent_.size()));
  size_.push_back(1);
  return parent_.size() - 1;
}

size_t UnionFind::Find(size_t x) {
  while (parent_[x] != x) {
    parent_[x] = parent_[parent_[x]];  // path halving
    x = parent_[x];
  }
  return x;
}

bool UnionFind::Union(size_t a, size_t b) {
  a = Find(a);
  b = Find(b);
  if (a == b) return false;
  if (size_[a] < size_[b]) std::swap(a, b);
  parent_[b] = static_cast<uint32_t>(a);
  size_[a] += size_[b];
  return true;
}

std::vector<std::vector<int>> ConnectedComponents(
    int num_vertices, const std::vector<std::pair<int, int>>& edges) {
  CHECK_GE(num_vertices, 0);
  UnionFind sets(static_cast<size_t>(num_vertices));
  for (const auto& [a, b] : edges) {
    CHECK(a >= 0 && a < num_vertices && b >= 0 && b < num_vertices)
        << "edge (" << a << ", " << b << ") of a graph of " << num_vertices
        << " vertices";
    sets.Union(a, b);
  }
  // Vertices in ascending order: a component is created at its smallest
  // vertex and filled in ascending order.
  std::vector<int> component_of_root(num_vertices, -1);
  std::vector<std::vector<int>> components;
  for (int v = 0; v < num_vertices; ++v) {
    int& component = component_of_root[sets.Find(v)];
    if (component < 0) {
      component = static_cast<int>(components.size());
      components.emplace_back();
    }
    components[component].push_back(v);
  }
  std::stable_sort(components.begin(), components.end(),
                   [](const std::vector<int>& a, const std::vector<int>& b) {
                     return a.size() > b.size();
                   });
  return components;
}

}  // namespace colmap_irav4
