#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace colmap_irav4 {

// Disjoint sets over the elements 0..Size()-1, with path halving and union by
// size (near-constant amortised time per operation). Which element becomes a
// set's root is an implementation detail: callers that need a deterministic
// representative use the smallest element (see ConnectedComponents). 8 bytes
// per element (32-bit parents and sizes: fewer than 2^32 elements).
class UnionFind {
 public:
  UnionFind() = default;
  explicit UnionFind(size_t num_elements);

  // Adds a singleton set and returns its element.
  size_t Add();
  size_t Size() const { return parent_.size(); }
  // The root of x's set.
  size_t Find(size_t x);
  // Merges the sets of a and b; returns false if they were already one set.
  bool Union(size_t a, size_t b);
  // The number of elements of x's set.
  size_t SetSize(size_t x) { return size_[Find(x)]; }

 private:
  std::vector<uint32_t> parent_;
  std::vector<uint32_t> size_;
};

// Connected components of the graph with vertices 0..num_vertices-1 and the
// given undirected edges (vertex pairs, each < num_vertices: CHECKed). Every
// vertex is in exactly one component (an isolated vertex is a component of
// size 1). Components are sorted ascending, ordered largest first; equal
// sizes keep the order of their smallest vertex.
std::vector<std::vector<int>> ConnectedComponents(
    int num_vertices, const std::vector<std::pair<int, int>>& edges);

}  // namespace colmap_irav4
